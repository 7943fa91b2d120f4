#pragma once
// The processes that share one mapping job: one process, or the ranks of an MPI job. The job
// knows nothing of MPI: whoever starts the ranks (the potmap command under mpirun) gives the
// job a JobRanks that moves bytes between them. Each rank maps a contiguous part of the scans
// or keyframes and sends its map to rank 0, which merges the maps and writes the outputs
// (docs/mapping-ranks.md). Bytes rather than file names: ranks on other machines need no file
// system shared with rank 0.
#include <cstddef>
#include <string>
#include <vector>

#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// A contiguous part [begin, end) of a run's scans or keyframes.
struct RankPart {
  std::size_t begin = 0, end = 0;
  std::size_t size() const { return end - begin; }
};

/// Rank `rank` of `size`'s part of [first, end): the ranks take equal contiguous parts in rank
/// order (rank 0 the first). Throws ArgumentError, naming `what` ("scans", "keyframes"), when
/// there are fewer than ranks.
RankPart rank_part(std::size_t first, std::size_t end, int rank, int size, const std::string& what);

/// The ranks of a job, as the job sees them.
class JobRanks {
 public:
  virtual ~JobRanks() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  /// Every rank's `bytes`, in rank order, on rank 0; an empty list on the others. Waits for
  /// every rank.
  virtual std::vector<std::string> gather(const std::string& bytes) = 0;
  /// This rank's part of [first, end) (rank_part()).
  RankPart part(std::size_t first, std::size_t end, const std::string& what) const {
    return rank_part(first, end, rank(), size(), what);
  }
};

}  // namespace potmap
POTMAP_CXX_API_END
