#pragma once
// The continuous occupancy map of SPEC section 2: M squared-exponential kernels, each with a
// position, a width gamma and a Gaussian weight (mean, variance), plus an optional bias weight.
//
//   phi_m(x) = exp(-gamma_m * |x - h_m|^2)
//   mu(x)    = b_mean + sum_m w_mean_m * phi_m(x)
//   s2(x)    = b_var  + sum_m w_var_m  * phi_m(x)^2
//   p(x)     = sigmoid(mu / sqrt(1 + pi * s2 / 8))

#include <cstddef>
#include <limits>
#include <string>
#include <vector>

#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// A kernel map in 2D or 3D. Plain data: fields may be filled directly; validate() checks them.
/// Positions are kept in double so that maps in large world frames (UTM, city scale) keep
/// millimetre precision; the device evaluators split them into two floats (see evaluate.hpp).
struct KernelMap {
  int dim = 2;                   ///< 2 or 3
  std::vector<double> position;  ///< size() * dim values, row-major (x0, y0[, z0], x1, ...), metres
  std::vector<double> gamma;     ///< kernel width, 1/m^2, > 0
  std::vector<double> w_mean;    ///< weight mean (dimensionless logit contribution)
  std::vector<double> w_var;     ///< weight variance, >= 0
  bool has_bias = false;         ///< whether bias_mean / bias_var take part
  double bias_mean = 0.0;        ///< bias weight mean (phi = 1 everywhere); used if has_bias
  double bias_var = 0.0;         ///< bias weight variance, >= 0; used if has_bias
  /// The cut-off exponent the map was learned with, > 0. A learner whose features stopped at
  /// gamma * d^2 = cutoff_tau never used a kernel's terms beyond it, so the fast evaluators
  /// may drop them: they cut at the smaller of this and EvalOptions::tau (3D drive maps, learned
  /// at 4.5, export in about half the time of the evaluators' own 18, with held-out scores
  /// equal to five decimals). Default infinity: the evaluators' own cut-off. evaluate_exact
  /// sums every term either way.
  double cutoff_tau = std::numeric_limits<double>::infinity();

  std::size_t size() const { return gamma.size(); }
  bool empty() const { return gamma.empty(); }
  /// Appends one kernel; `pos` holds `dim` coordinates.
  void push_back(const double* pos, double g, double wm, double wv);
  /// Reserves room for n kernels.
  void reserve(std::size_t n);
  /// Throws ArgumentError naming the first kernel index and value that breaks the model:
  /// dimension not 2 or 3, array sizes that disagree, non-finite values, gamma <= 0, w_var < 0,
  /// cutoff_tau not positive.
  /// `source` (a file name, or empty) is prefixed to the message.
  void validate(const std::string& source = "") const;
  /// Axis-aligned bounds of the kernel positions: lo[d], hi[d] for d < dim. Empty map: zeros.
  void bounds(double lo[3], double hi[3]) const;
};

/// Exponent at which a kernel is cut off: terms with gamma * d^2 > tau are dropped by the fast
/// evaluators. exp(-18) = 1.5e-8 of the weight. See SPEC section 2.
inline constexpr double kDefaultCutoffTau = 18.0;

}  // namespace potmap
POTMAP_CXX_API_END
