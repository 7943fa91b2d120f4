#pragma once
// Look-ahead in the experiments: each scan's held-out samples scored on the map as it stood
// before that scan was learned (what a planner reads of the space ahead), for every method that
// learns a task's scans in order, and which of those samples lay beyond every earlier sample's
// reach (where only a prior, a transferred one for POT and RePOT, can speak).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <vector>

#include "potmap/data/labelled_points.hpp"
#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap::experiment {

struct MapTask;

/// The look-ahead of one method on one task (MapTask::lookahead). A method calls before() as
/// it reaches each scan, before learning it, and hands take() to FittedMap::lookahead.
class LookAheadScorer {
 public:
  /// Groups task.lookahead's samples by scan index; inactive when the task has none.
  explicit LookAheadScorer(const MapTask& task);
  bool active() const { return points_ != nullptr; }
  /// Scores the samples of scan `scan` (an index as in LabelledPoints::scan) with `query`
  /// (n points of dim coordinates -> n probabilities), unless it is the task's first scan
  /// (no map yet) or has none. The time spent is kept (seconds()), for the caller to leave
  /// out of its fitting time.
  void before(std::int64_t scan,
              const std::function<void(const double* points, std::size_t n, double* prob)>& query);
  /// Per sample of the task's look-ahead: its probability, NaN where it was not scored.
  std::vector<float> take() { return std::move(prob_); }
  double seconds() const { return seconds_; }

 private:
  const LabelledPoints* points_ = nullptr;
  std::int64_t first_ = 0;
  std::map<std::int64_t, std::vector<std::size_t>> by_scan_;
  std::vector<float> prob_;
  double seconds_ = 0;
};

/// Per sample of `test`: 1 when no sample of `train` from an earlier scan (a smaller
/// LabelledPoints::scan) lies within `reach` metres of it. A method-free definition of
/// "beyond reach", the same for a grid and a kernel map. Throws ArgumentError for a reach
/// that is not positive or samples without scan indices.
std::vector<std::uint8_t> beyond_reach(const LabelledPoints& test, const LabelledPoints& train,
                                       double reach);

}  // namespace potmap::experiment
POTMAP_CXX_API_END
