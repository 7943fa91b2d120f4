// Look-ahead scoring of the experiments (lookahead.hpp).
#include "potmap/experiments/lookahead.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <unordered_map>

#include "potmap/error.hpp"
#include "potmap/experiments/experiment.hpp"

namespace potmap::experiment {

LookAheadScorer::LookAheadScorer(const MapTask& task) : points_(task.lookahead) {
  if (!points_) return;
  first_ = task.first_index;
  prob_.assign(points_->size(), std::numeric_limits<float>::quiet_NaN());
  if (points_->scan.size() != points_->size())
    throw ArgumentError("look-ahead: the held-out samples carry no scan indices");
  for (std::size_t i = 0; i < points_->size(); ++i) by_scan_[points_->scan[i]].push_back(i);
}

void LookAheadScorer::before(
    std::int64_t scan,
    const std::function<void(const double* points, std::size_t n, double* prob)>& query) {
  if (!points_ || scan <= first_) return;
  const auto it = by_scan_.find(scan);
  if (it == by_scan_.end()) return;
  const auto t0 = std::chrono::steady_clock::now();
  const int d = points_->dim;
  std::vector<double> pts;
  pts.reserve(it->second.size() * std::size_t(d));
  for (std::size_t i : it->second)
    pts.insert(pts.end(), &points_->position[i * d], &points_->position[i * d] + d);
  std::vector<double> p(it->second.size());
  query(pts.data(), p.size(), p.data());
  for (std::size_t k = 0; k < p.size(); ++k)
    prob_[it->second[k]] = static_cast<float>(std::min(1.0, std::max(0.0, p[k])));
  seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

namespace {

// Cells of edge `reach`: a point's neighbours within reach lie in the 3^dim cells around it.
struct CellKey {
  std::int64_t c[3];
  bool operator==(const CellKey& o) const {
    return c[0] == o.c[0] && c[1] == o.c[1] && c[2] == o.c[2];
  }
};
struct CellHash {
  std::size_t operator()(const CellKey& k) const {
    std::uint64_t h = 1469598103934665603ull;
    for (std::int64_t v : k.c) h = (h ^ std::uint64_t(v)) * 1099511628211ull;
    return std::size_t(h);
  }
};

CellKey cell_of(const double* p, int dim, double reach) {
  CellKey k{{0, 0, 0}};
  for (int d = 0; d < dim; ++d) k.c[d] = std::int64_t(std::floor(p[d] / reach));
  return k;
}

}  // namespace

std::vector<std::uint8_t> beyond_reach(const LabelledPoints& test, const LabelledPoints& train,
                                       double reach) {
  if (!(reach > 0) || !std::isfinite(reach))
    throw ArgumentError("look-ahead: reach must be positive metres, got " + std::to_string(reach));
  if (test.scan.size() != test.size() || train.scan.size() != train.size())
    throw ArgumentError("look-ahead: samples carry no scan indices");
  const int dim = train.empty() ? test.dim : train.dim;
  std::map<std::int64_t, std::vector<std::size_t>> tests, trains;
  for (std::size_t i = 0; i < test.size(); ++i) tests[test.scan[i]].push_back(i);
  for (std::size_t i = 0; i < train.size(); ++i) trains[train.scan[i]].push_back(i);
  std::unordered_map<CellKey, std::vector<std::size_t>, CellHash> grid;
  std::vector<std::uint8_t> out(test.size(), 1);
  const double r2 = reach * reach;
  auto near_any = [&](const double* p) {
    const CellKey c = cell_of(p, dim, reach);
    const int span[3] = {1, 1, dim == 3 ? 1 : 0};
    for (int a = -span[0]; a <= span[0]; ++a)
      for (int b = -span[1]; b <= span[1]; ++b)
        for (int z = -span[2]; z <= span[2]; ++z) {
          const auto it = grid.find(CellKey{{c.c[0] + a, c.c[1] + b, c.c[2] + z}});
          if (it == grid.end()) continue;
          for (std::size_t j : it->second) {
            double s = 0;
            for (int d = 0; d < dim; ++d) {
              const double e = p[d] - train.position[j * dim + d];
              s += e * e;
            }
            if (s <= r2) return true;
          }
        }
    return false;
  };
  // Scans in order: a scan's test samples against the earlier scans' samples, then its own
  // training samples join them.
  auto ti = trains.begin();
  for (const auto& [scan, idx] : tests) {
    for (; ti != trains.end() && ti->first < scan; ++ti)
      for (std::size_t j : ti->second)
        grid[cell_of(&train.position[j * dim], dim, reach)].push_back(j);
    for (std::size_t i : idx) out[i] = near_any(&test.position[i * dim]) ? 0 : 1;
  }
  return out;
}

}  // namespace potmap::experiment
