// Ordering atoms by per-class distances (see class_ranking.hpp).
#include "class_ranking.hpp"

#include <algorithm>
#include <numeric>

namespace potmap::detail {

std::vector<std::size_t> order_by_class_distance(const std::vector<double>& dh,
                                                 const std::vector<double>& df, std::size_t k) {
  const std::size_t n = dh.size();
  double mh = 0, mf = 0;
  for (std::size_t i = 0; i < n; ++i) {
    mh = std::max(mh, dh[i]);
    mf = std::max(mf, df[i]);
  }
  std::vector<double> cost(n);
  for (std::size_t i = 0; i < n; ++i) {
    const int missing = (dh[i] < 0) + (df[i] < 0);
    // Missing classes order first by how many are missing, then by the cost of the rest.
    cost[i] = 4.0 * missing + (mh > 0 ? std::max(dh[i], 0.0) / mh : 0) +
              (mf > 0 ? std::max(df[i], 0.0) / mf : 0);
  }
  std::vector<std::size_t> idx(n);
  std::iota(idx.begin(), idx.end(), std::size_t{0});
  auto better = [&](std::size_t a, std::size_t b) {
    return cost[a] != cost[b] ? cost[a] < cost[b] : a < b;
  };
  if (k == 0 || k >= n) {
    std::sort(idx.begin(), idx.end(), better);
    return idx;
  }
  std::partial_sort(idx.begin(), idx.begin() + k, idx.end(), better);
  idx.resize(k);
  return idx;
}

}  // namespace potmap::detail
