#pragma once
// The processes of one tiled raster job: a single process, or the ranks of an MPI job when the
// command runs under mpirun (and was built with MPI). Ranks claim tiles from a shared counter
// on rank 0, so a rank that draws cheap tiles takes more of them (load balancing for tiles of
// uneven cost); rank 0 assembles once every rank is done.

#include <cstddef>

namespace potmap::cli {

class RasterRanks {
 public:
  /// Starts MPI if this process was launched by mpirun (OMPI_COMM_WORLD_SIZE or PMI_SIZE set)
  /// and the build has MPI; otherwise a single rank.
  RasterRanks();
  ~RasterRanks();
  RasterRanks(const RasterRanks&) = delete;
  RasterRanks& operator=(const RasterRanks&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  /// Rank among the processes on this node: picks this rank's OpenCL device.
  int local_rank() const { return local_rank_; }
  /// The next unclaimed tile index, or `total` when none is left.
  std::size_t claim(std::size_t total);
  /// Waits for every rank; returns true if every rank passed `ok`.
  bool all_ok(bool ok);
  /// The sum of `v` over every rank (also waits for every rank).
  std::size_t sum(std::size_t v);
  /// Ends the whole job from one failing rank (the others would wait forever); never returns.
  [[noreturn]] void abort(int code);

 private:
  int rank_ = 0, size_ = 1, local_rank_ = 0;
  bool mpi_ = false;
  std::size_t next_ = 0;  // single-process counter
  void* window_ = nullptr;
  long* counter_ = nullptr;
};

}  // namespace potmap::cli
