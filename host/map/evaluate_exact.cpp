// The reference evaluator: every kernel, in double, no cut-off. Slow and simple on purpose.
#include <cmath>

#include <Eigen/Core>

#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"

namespace potmap {

namespace {
// Kernel evaluations below which evaluate_exact() runs on one thread: after a parallel region
// OpenMP's workers spin for milliseconds (OMP_WAIT_POLICY unset), taking a core from the
// device's threads (PoCL's CPU device); `potmap map` scores every scan's map on its held-out
// samples (about a million evaluations at 360 beams), and the spinning slowed the next scan's
// transfer by about 1.5 ms. 2^23 evaluations take some 30 ms on one core: worth the spin.
constexpr double kParallelEvaluations = 8388608;
}  // namespace

double probit_probability(double mean, double var) {
  const double z = mean / std::sqrt(1.0 + M_PI * var / 8.0);
  return 1.0 / (1.0 + std::exp(-z));
}

GridSpec GridSpec::covering(int dim, const double lo[3], const double hi[3], double resolution) {
  if (dim != 2 && dim != 3) throw ArgumentError("GridSpec: dimension must be 2 or 3");
  if (!(resolution > 0) || !std::isfinite(resolution))
    throw ArgumentError("GridSpec: resolution must be positive, got " + std::to_string(resolution));
  GridSpec g;
  g.dim = dim;
  g.resolution = resolution;
  for (int d = 0; d < 3; ++d) {
    if (d >= dim) {
      g.count[d] = 1;
      continue;
    }
    if (!(hi[d] > lo[d]))
      throw ArgumentError("GridSpec: empty extent on axis " + std::to_string(d) + ": [" +
                          std::to_string(lo[d]) + ", " + std::to_string(hi[d]) + "]");
    g.origin[d] = lo[d];
    g.count[d] = static_cast<std::size_t>(std::ceil((hi[d] - lo[d]) / resolution - 1e-9));
  }
  return g;
}

MapValuesExact evaluate_exact(const KernelMap& map, const double* points, std::size_t n) {
  map.validate();
  const int dim = map.dim;
  MapValuesExact out;
  out.mean.resize(n);
  out.var.resize(n);
  out.prob.resize(n);
  using Mat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const Eigen::Map<const Mat> h(map.position.data(), map.size(), dim);
  const Eigen::Map<const Eigen::VectorXd> g(map.gamma.data(), map.size());
  const Eigen::Map<const Eigen::VectorXd> wm(map.w_mean.data(), map.size());
  const Eigen::Map<const Eigen::VectorXd> wv(map.w_var.data(), map.size());
  const long long count = static_cast<long long>(n);
  const bool parallel = double(n) * double(map.size()) >= kParallelEvaluations;
#pragma omp parallel if (parallel)
  {
    // One pair of work vectors a thread, not a point: a fresh pair of map.size() doubles for
    // every point cost page faults, most of the reference's time under AddressSanitizer.
    Eigen::VectorXd d2(map.size());
    Eigen::ArrayXd phi(map.size());
#pragma omp for schedule(dynamic, 64)
    for (long long i = 0; i < count; ++i) {
      Eigen::Map<const Eigen::RowVectorXd> x(points + i * dim, dim);
      d2.noalias() = (h.rowwise() - x).rowwise().squaredNorm();
      phi = (-g.array() * d2.array()).exp();
      double mean = wm.dot(phi.matrix());
      double var = wv.dot((phi * phi).matrix());
      if (map.has_bias) {
        mean += map.bias_mean;
        var += map.bias_var;
      }
      out.mean[i] = mean;
      out.var[i] = var;
      out.prob[i] = probit_probability(mean, var);
    }
  }
  return out;
}

MapValuesExact evaluate_exact(const KernelMap& map, const GridSpec& grid) {
  std::vector<double> pts;
  pts.reserve(grid.cells() * grid.dim);
  const std::size_t nz = grid.dim == 3 ? grid.count[2] : 1;
  for (std::size_t k = 0; k < nz; ++k)
    for (std::size_t j = 0; j < grid.count[1]; ++j)
      for (std::size_t i = 0; i < grid.count[0]; ++i) {
        pts.push_back(grid.origin[0] + (i + 0.5) * grid.resolution);
        pts.push_back(grid.origin[1] + (j + 0.5) * grid.resolution);
        if (grid.dim == 3) pts.push_back(grid.origin[2] + (k + 0.5) * grid.resolution);
      }
  if (grid.dim != map.dim) throw ArgumentError("evaluate_exact: grid and map dimensions differ");
  return evaluate_exact(map, pts.data(), grid.cells());
}

}  // namespace potmap
