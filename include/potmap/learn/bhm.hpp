#pragma once
// Bayesian Hilbert maps (SPEC section 3): Bayesian logistic regression on kernel features with a
// diagonal Gaussian posterior over the weights, found with the Jaakkola-Jordan bound and EM over
// one local variable xi_n per sample.
//
//   lambda(xi) = (sigmoid(xi) - 1/2) / (2 xi)
//   E-step:  1/wvar = 1/wvar0 + 2 sum_n lambda(xi_n) phi_nm^2
//            wbar   = wvar (wbar0 / wvar0 + sum_n (y_n - 1/2) phi_nm)
//   M-step:  xi_n^2 = sum_m phi_nm^2 wvar_m + (sum_m phi_nm wbar_m)^2
//
// The update changes only w_mean, w_var (and the bias weight if the map has one); positions and
// widths stay as given, so any KernelMap can be the prior (RePOT's refinement, SPEC 4.7).
//
// Sequential use: the posterior of one scan is the prior of the next. With the xi fixed (one EM
// iteration) both sums are additive over samples, so updating scan by scan gives exactly the
// batch fit over all scans; with EM over xi the two differ because xi_n depends on the posterior
// at the time sample n is seen.

#include <cstddef>

#include "potmap/data/labelled_points.hpp"
#include "potmap/export.h"
#include "potmap/map/kernel_map.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct BhmOptions {
  /// E-steps per update (default 3). Each but the last is followed by an M-step that refits xi
  /// to the current posterior; 1 means one E-step with xi = xi_init for every sample.
  int em_iterations = 3;
  /// Starting value of every xi_n (dimensionless, > 0; default 1).
  double xi_init = 1.0;
  /// Kernel cut-off exponent: a sample ignores kernels with gamma d^2 > tau (default 18).
  double tau = kDefaultCutoffTau;
};

/// A BHM prior: kernels on a regular grid over [lo, hi] (metres, `dim` axes used), `spacing`
/// metres apart (> 0), all with width `gamma` (1/m^2, > 0), weight mean `w_mean0` (default 0)
/// and variance `w_var0` (default 10000, the authors' default). The grid starts at lo and
/// includes hi when (hi - lo) is a multiple of the spacing. `bias`: add a bias weight with the
/// same prior (default false). Throws ArgumentError on bad arguments.
KernelMap bhm_grid_prior(int dim, const double lo[3], const double hi[3], double spacing,
                         double gamma, double w_mean0 = 0.0, double w_var0 = 1e4,
                         bool bias = false);

/// One BHM update on the CPU in double precision (the reference): `map` holds the prior on entry
/// and the posterior on return. Samples of any scan index are used together. Throws
/// ArgumentError if the dimensions differ, the map is invalid, or a prior variance is zero.
void bhm_update_reference(KernelMap& map, const LabelledPoints& samples,
                          const BhmOptions& options = {});

/// The same update with the sums over samples on the OpenCL device of `ctx` (single precision
/// sums, double-precision posterior on the host).
void bhm_update(Context& ctx, KernelMap& map, const LabelledPoints& samples,
                const BhmOptions& options = {});

/// Sequential BHM: updates `map` with the samples of each scan index in increasing order, the
/// posterior of one scan being the prior of the next. `ctx` null: the CPU reference.
void bhm_update_sequential(Context* ctx, KernelMap& map, const LabelledPoints& samples,
                           const BhmOptions& options = {});

}  // namespace potmap
POTMAP_CXX_API_END
