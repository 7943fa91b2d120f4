#pragma once
// The processes of one `potmap mapping` run: a single process, or the ranks of an MPI job when
// the command runs under mpirun (and was built with MPI). Each rank maps a contiguous part of
// the scans (or keyframes); the ranks send their maps and held-out samples to rank 0 as bytes,
// which merges the maps and writes the outputs (docs/mapping-ranks.md). Bytes rather than file
// names: ranks on other machines need no file system shared with rank 0.

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "potmap/job/job_ranks.hpp"

namespace potmap::cli {

/// The ranks as the library's mapping job sees them (potmap/job/job_ranks.hpp), and the raster
/// job's.
class MappingRanks : public JobRanks {
 public:
  /// Starts MPI if this process was launched by mpirun (OMPI_COMM_WORLD_SIZE, PMI_SIZE or
  /// PMIX_RANK set) and the build has MPI; otherwise a single rank.
  MappingRanks();
  ~MappingRanks();
  MappingRanks(const MappingRanks&) = delete;
  MappingRanks& operator=(const MappingRanks&) = delete;

  int rank() const override { return rank_; }
  int size() const override { return size_; }
  /// Rank among the processes on this node: picks this rank's OpenCL device.
  int local_rank() const { return local_rank_; }

  /// Every rank's `bytes`, in rank order, on rank 0; an empty list on the others. Waits for
  /// every rank.
  std::vector<std::string> gather(const std::string& bytes) override;

  /// The device this rank opens: `requested` when named (or POTMAP_DEVICE set), else the
  /// node's devices shared round-robin by local rank.
  std::string device(const std::string& requested) const;

  /// Runs `job`. On several ranks an exception ends the whole job (the other ranks would wait
  /// for this one's bytes forever) after printing it with the rank's number; on one process it
  /// propagates as from any command.
  int guard(const std::function<int()>& job);

 private:
  int rank_ = 0, size_ = 1, local_rank_ = 0;
  bool mpi_ = false;
};

}  // namespace potmap::cli
