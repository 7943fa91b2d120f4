#include "raster_ranks.hpp"

#include "mpi_start.hpp"

#include <cstdlib>

#ifdef POTMAP_WITH_MPI
#include <mpi.h>
#endif

namespace potmap::cli {

#ifdef POTMAP_WITH_MPI

RasterRanks::RasterRanks() {
  if (!launched_by_mpirun()) return;
  const MpiPlace p = start_mpi();
  mpi_ = true;
  rank_ = p.rank;
  size_ = p.size;
  local_rank_ = p.local_rank;
  // The shared tile counter lives in rank 0's window; the others reach it one-sided.
  MPI_Win win;
  MPI_Win_allocate(rank_ == 0 ? sizeof(long) : 0, sizeof(long), MPI_INFO_NULL, MPI_COMM_WORLD,
                   &counter_, &win);
  if (rank_ == 0) *counter_ = 0;
  window_ = new MPI_Win(win);
  MPI_Barrier(MPI_COMM_WORLD);
}

RasterRanks::~RasterRanks() {
  if (!mpi_) return;
  auto* win = static_cast<MPI_Win*>(window_);
  MPI_Win_free(win);
  delete win;
  MPI_Finalize();
}

std::size_t RasterRanks::claim(std::size_t total) {
  if (!mpi_) return next_ < total ? next_++ : total;
  MPI_Win win = *static_cast<MPI_Win*>(window_);
  const long one = 1;
  long got = 0;
  MPI_Win_lock(MPI_LOCK_SHARED, 0, 0, win);
  MPI_Fetch_and_op(&one, &got, MPI_LONG, 0, 0, MPI_SUM, win);
  MPI_Win_unlock(0, win);
  return got < long(total) ? std::size_t(got) : total;
}

bool RasterRanks::all_ok(bool ok) {
  if (!mpi_) return ok;
  int mine = ok ? 1 : 0, all = 0;
  MPI_Allreduce(&mine, &all, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  return all == 1;
}

std::size_t RasterRanks::sum(std::size_t v) {
  if (!mpi_) return v;
  unsigned long long mine = v, all = 0;
  MPI_Allreduce(&mine, &all, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  return std::size_t(all);
}

void RasterRanks::abort(int code) {
  if (mpi_) MPI_Abort(MPI_COMM_WORLD, code);
  std::exit(code);
}

#else  // no MPI in this build: always one rank

RasterRanks::RasterRanks() {
  (void)window_;
  (void)counter_;
  (void)mpi_;
}
RasterRanks::~RasterRanks() = default;
std::size_t RasterRanks::claim(std::size_t total) {
  return next_ < total ? next_++ : total;
}
bool RasterRanks::all_ok(bool ok) {
  return ok;
}
std::size_t RasterRanks::sum(std::size_t v) {
  return v;
}
void RasterRanks::abort(int code) {
  std::exit(code);
}

#endif

}  // namespace potmap::cli
