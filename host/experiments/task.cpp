// Building a MapTask: the split is label_scan's, applied to beams (split_beams) and samples alike.
#include <algorithm>
#include <cmath>

#include "potmap/error.hpp"
#include "potmap/experiments/experiment.hpp"

namespace potmap::experiment {

MapTask make_task(const std::vector<Scan>& scans, const LabelOptions& labels, LabelledPoints& test,
                  double area_margin, std::int64_t first_index) {
  MapTask task;
  if (scans.empty()) throw ArgumentError("make_task: no scans");
  task.dim = scans.front().dim;
  task.first_index = first_index;
  LabelledSplit split;
  task.train_scans.reserve(scans.size());
  for (std::size_t i = 0; i < scans.size(); ++i) {
    if (scans[i].dim != task.dim) throw ArgumentError("make_task: scans of different dimension");
    const auto t = first_index + static_cast<std::int64_t>(i);
    label_scan(scans[i], t, labels, split);
    task.train_scans.push_back(split_beams(scans[i], t, labels));
  }
  task.train = std::move(split.train);
  test = std::move(split.test);
  task.train.dim = test.dim = task.dim;

  const int d = task.dim;
  double slo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, shi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  double hlo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hhi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  const LabelledPoints& tr = task.train;
  for (std::size_t i = 0; i < tr.size(); ++i)
    for (int k = 0; k < d; ++k) {
      const double v = tr.position[i * d + k];
      slo[k] = std::min(slo[k], v);
      shi[k] = std::max(shi[k], v);
      if (tr.label[i]) {
        hlo[k] = std::min(hlo[k], v);
        hhi[k] = std::max(hhi[k], v);
      }
    }
  if (tr.empty()) throw InputError("make_task: the scans gave no training samples");
  const bool any_hit = hlo[0] <= hhi[0];
  for (int k = 0; k < d; ++k) {
    task.lo[k] = any_hit ? std::max(slo[k], hlo[k] - area_margin) : slo[k];
    task.hi[k] = any_hit ? std::min(shi[k], hhi[k] + area_margin) : shi[k];
    if (task.hi[k] - task.lo[k] < 1e-3) task.hi[k] = task.lo[k] + 1e-3;
  }
  return task;
}

}  // namespace potmap::experiment
