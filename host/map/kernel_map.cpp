#include "potmap/map/kernel_map.hpp"

#include <cmath>
#include <limits>
#include <sstream>

#include "map/point_bounds.hpp"
#include "potmap/error.hpp"

namespace potmap {

void KernelMap::push_back(const double* pos, double g, double wm, double wv) {
  position.insert(position.end(), pos, pos + dim);
  gamma.push_back(g);
  w_mean.push_back(wm);
  w_var.push_back(wv);
}

void KernelMap::reserve(std::size_t n) {
  position.reserve(n * dim);
  gamma.reserve(n);
  w_mean.reserve(n);
  w_var.reserve(n);
}

void KernelMap::validate(const std::string& source) const {
  const std::string where = source.empty() ? "kernel map" : source;
  auto fail = [&](const std::string& what) { throw ArgumentError(where + ": " + what); };
  if (dim != 2 && dim != 3) fail("dimension must be 2 or 3, got " + std::to_string(dim));
  if (!(cutoff_tau > 0))
    fail("cut-off exponent must be positive, got " + std::to_string(cutoff_tau));
  const std::size_t m = gamma.size();
  if (w_mean.size() != m || w_var.size() != m || position.size() != m * dim) {
    std::ostringstream s;
    s << "array sizes disagree: gamma " << m << ", w_mean " << w_mean.size() << ", w_var "
      << w_var.size() << ", position " << position.size() << " (expected " << m * dim << ")";
    fail(s.str());
  }
  for (std::size_t i = 0; i < m; ++i) {
    for (int d = 0; d < dim; ++d)
      if (!std::isfinite(position[i * dim + d])) {
        std::ostringstream s;
        s << "kernel " << i << ": position[" << d << "] is " << position[i * dim + d];
        fail(s.str());
      }
    if (!(gamma[i] > 0) || !std::isfinite(gamma[i])) {
      std::ostringstream s;
      s << "kernel " << i << ": gamma must be positive and finite, got " << gamma[i];
      fail(s.str());
    }
    if (!std::isfinite(w_mean[i])) {
      std::ostringstream s;
      s << "kernel " << i << ": w_mean is " << w_mean[i];
      fail(s.str());
    }
    if (!(w_var[i] >= 0) || !std::isfinite(w_var[i])) {
      std::ostringstream s;
      s << "kernel " << i << ": w_var must be non-negative and finite, got " << w_var[i];
      fail(s.str());
    }
  }
  if (has_bias && (!std::isfinite(bias_mean) || !(bias_var >= 0) || !std::isfinite(bias_var))) {
    std::ostringstream s;
    s << "bias weight invalid: mean " << bias_mean << ", variance " << bias_var;
    fail(s.str());
  }
}

void KernelMap::bounds(double lo[3], double hi[3]) const {
  detail::point_bounds(position, size(), dim, lo, hi);
}

}  // namespace potmap
