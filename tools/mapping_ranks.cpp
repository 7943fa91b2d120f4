#include "mapping_ranks.hpp"

#include "mpi_start.hpp"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <iostream>

#include "potmap/error.hpp"
#include "potmap/runtime/context.hpp"

#ifdef POTMAP_WITH_MPI
#include <mpi.h>
#endif

namespace potmap::cli {

namespace {

#ifdef POTMAP_WITH_MPI
// MPI counts in int: a map of several GB goes in pieces under 1 GiB.
constexpr std::size_t kPiece = std::size_t(1) << 30;

void send_bytes(const std::string& b, int to) {
  const std::uint64_t n = b.size();
  MPI_Send(&n, 1, MPI_UINT64_T, to, 0, MPI_COMM_WORLD);
  for (std::size_t at = 0; at < b.size(); at += kPiece)
    MPI_Send(b.data() + at, int(std::min(kPiece, b.size() - at)), MPI_BYTE, to, 1, MPI_COMM_WORLD);
}

std::string receive_bytes(int from) {
  std::uint64_t n = 0;
  MPI_Recv(&n, 1, MPI_UINT64_T, from, 0, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  std::string b(n, '\0');
  for (std::size_t at = 0; at < b.size(); at += kPiece)
    MPI_Recv(b.data() + at, int(std::min(kPiece, b.size() - at)), MPI_BYTE, from, 1, MPI_COMM_WORLD,
             MPI_STATUS_IGNORE);
  return b;
}
#endif

}  // namespace

MappingRanks::MappingRanks() {
#ifdef POTMAP_WITH_MPI
  if (!launched_by_mpirun()) return;
  const MpiPlace p = start_mpi();  // only the main thread calls MPI, never the mapper's workers
  mpi_ = true;
  rank_ = p.rank;
  size_ = p.size;
  local_rank_ = p.local_rank;
#else
  if (launched_by_mpirun())
    std::cerr << "potmap: warning: started by mpirun, but this potmap was built without MPI: "
                 "every process maps every scan (configure with libopenmpi-dev installed)\n";
#endif
}

MappingRanks::~MappingRanks() {
#ifdef POTMAP_WITH_MPI
  if (mpi_) MPI_Finalize();
#endif
}

std::vector<std::string> MappingRanks::gather(const std::string& bytes) {
  if (!mpi_) return {bytes};
#ifdef POTMAP_WITH_MPI
  if (rank_ != 0) {
    send_bytes(bytes, 0);
    return {};
  }
  std::vector<std::string> all{bytes};
  for (int r = 1; r < size_; ++r) all.push_back(receive_bytes(r));
  return all;
#else
  return {bytes};
#endif
}

std::string MappingRanks::device(const std::string& requested) const {
  if (size_ == 1 || !requested.empty() || std::getenv("POTMAP_DEVICE")) return requested;
  const auto devices = list_devices();
  if (devices.empty()) return requested;
  return devices[std::size_t(local_rank_) % devices.size()].name;
}

int MappingRanks::guard(const std::function<int()>& job) {
  if (size_ == 1) return job();
  try {
    return job();
  } catch (const std::exception& e) {
    // One write, so that the ranks' lines do not interleave.
    const std::string line = "potmap: rank " + std::to_string(rank_) + " of " +
                             std::to_string(size_) + ": error: " + e.what() + "\n";
    std::fputs(line.c_str(), stderr);
    std::fflush(stderr);
#ifdef POTMAP_WITH_MPI
    MPI_Abort(MPI_COMM_WORLD, 1);
#endif
    std::exit(1);
  }
}

}  // namespace potmap::cli
