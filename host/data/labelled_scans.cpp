// Scans rebuilt from BHM labelled samples (t, x, y[, z], occupied).
#include <map>

#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"

namespace potmap {

std::vector<Scan> scans_from_labelled(const LabelledPoints& pts, double max_range) {
  const int d = pts.dim;
  if (d != 2 && d != 3) throw ArgumentError("scans_from_labelled: dim must be 2 or 3");
  struct Acc {
    Scan scan;
    double free_sum[3] = {0, 0, 0};
    double hit_sum[3] = {0, 0, 0};
    std::size_t nfree = 0;
  };
  std::map<std::int64_t, Acc> by_t;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const std::int64_t t = pts.scan.size() == pts.size() ? pts.scan[i] : 0;
    Acc& a = by_t[t];
    const double* p = &pts.position[i * d];
    if (pts.label[i]) {
      for (int k = 0; k < d; ++k) {
        a.scan.hits.push_back(p[k]);
        a.hit_sum[k] += p[k];
      }
    } else {
      for (int k = 0; k < d; ++k) a.free_sum[k] += p[k];
      ++a.nfree;
    }
  }
  std::vector<Scan> out;
  out.reserve(by_t.size());
  for (auto& [t, a] : by_t) {
    Scan& s = a.scan;
    s.dim = d;
    s.timestamp = static_cast<double>(t);
    s.max_range = max_range;
    const std::size_t nh = s.hits.size() / d;
    double c[3] = {0, 0, 0};
    for (int k = 0; k < d; ++k)
      c[k] = a.nfree ? a.free_sum[k] / a.nfree : nh ? a.hit_sum[k] / nh : 0;
    if (d == 2) {
      s.pose2d = {c[0], c[1], 0};
    } else {
      s.pose3d[3] = c[0];
      s.pose3d[7] = c[1];
      s.pose3d[11] = c[2];
    }
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace potmap
