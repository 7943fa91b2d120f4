#pragma once
// MPI's start for the commands that share work between ranks (`potmap raster`, `potmap
// mapping`): whether mpirun started the process, and the process's place among the ranks.

namespace potmap::cli {

/// Whether mpirun started this process (Open MPI, or a PMI / PMIx launcher).
bool launched_by_mpirun();

/// This process's rank, the number of ranks and its rank among those on its node.
struct MpiPlace {
  int rank = 0, size = 1, local_rank = 0;
};

#ifdef POTMAP_WITH_MPI
/// MPI_Init_thread with MPI_THREAD_FUNNELED (only the main thread calls MPI; worker threads
/// never do) and this process's place. The caller calls MPI_Finalize.
MpiPlace start_mpi();
#endif

}  // namespace potmap::cli
