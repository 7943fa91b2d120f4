#pragma once
// Automorphing Bayesian Hilbert maps (SPEC section 3): every kernel m has its own variational
// distributions, learned offline by stochastic variational inference,
//
//   q(w_m)     = Normal(w_loc_m, softplus(w_s_m))          prior Normal(0, sd w_prior_sd)
//   q(h_m,d)   = Normal(h_loc_md, softplus(h_s_md))        prior Normal(grid_md, sd h_prior_sd)
//   q(gamma_m) = LogNormal(g_loc_m, softplus(g_s_m))       prior Gamma(shape, rate)
//   q(b)       = Normal(b_loc, softplus(b_s))              prior Normal(0, sd w_prior_sd)
//
// with the Bernoulli likelihood of f_n = b + sum_m w_m exp(-gamma_m |x_n - h_m|^2). The ELBO's
// gradient is taken by reparameterisation (w = loc + sd * eps, gamma = exp(loc + sd * eps)) with
// the derivatives of f written out by hand; every KL term is analytic, the LogNormal-vs-Gamma one
// included: KL = -H[q] - E_q[log p], H[q] = mu + 1/2 + log(s sqrt(2 pi)),
// E_q[log p] = a log b - lgamma(a) + (a - 1) mu - b exp(mu + s^2 / 2).

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "potmap/data/labelled_points.hpp"
#include "potmap/export.h"
#include "potmap/map/kernel_map.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// Priors of SPEC section 3 (the authors' public code).
struct AbhmPrior {
  double w_sd = 900.0;    ///< sd of the Normal prior of every weight and the bias
  double h_sd = 10.0;     ///< sd of the Normal prior of each position coordinate, metres
  double g_shape = 1.05;  ///< Gamma prior of gamma: shape (dimensionless)
  double g_rate = 12.0;   ///< Gamma prior of gamma: rate, m^2
};

/// The variational parameters. Scales are unconstrained: sd = softplus(s) = log(1 + e^s).
struct AbhmParams {
  int dim = 2;
  std::vector<double> h_grid;      ///< prior means of the positions (M * dim), metres
  std::vector<double> w_loc, w_s;  ///< M each
  std::vector<double> h_loc, h_s;  ///< M * dim each, metres (h_s: softplus gives metres)
  std::vector<double> g_loc, g_s;  ///< M each; log gamma has mean g_loc (gamma in 1/m^2)
  double b_loc = 0.0, b_s = 0.0;   ///< bias weight
  std::size_t size() const { return w_loc.size(); }
  /// The trainable parameters as one vector (order: w_loc, w_s, h_loc, h_s, g_loc, g_s, b_loc,
  /// b_s) and back. h_grid and dim are not trainable.
  std::vector<double> flat() const;
  void set_flat(const std::vector<double>& v);
  /// The kernel map of the means of q: positions h_loc, gamma = exp(g_loc) (the LogNormal's
  /// median; `mean_gamma` true: its mean exp(loc + sd^2/2)), w_mean = w_loc, w_var = sd_w^2,
  /// bias likewise.
  KernelMap to_map(bool mean_gamma = false) const;
};

/// Writes the variational parameters (binary, little-endian, with a CRC-32; atomically) and
/// reads them back. read throws InputError naming the file and the byte offset for a wrong,
/// truncated, corrupt or unreadable file.
void write_abhm_params(const AbhmParams& params, const std::string& path);
AbhmParams read_abhm_params(const std::string& path);

/// Initial parameters: kernels on the regular grid over [lo, hi] (dim axes, metres) with the
/// given spacing (> 0), or, with `halton` true, `count` kernels at the points of the Halton
/// sequence (bases 2, 3, 5) over the box. Starting values: w_loc 0, sd_w 0.1, h_loc at the
/// grid, sd_h 0.01 * spacing (Halton: the equivalent spacing), gamma `gamma0` (1/m^2) with
/// log-sd 0.1, bias 0 with sd 0.1.
AbhmParams abhm_init_grid(int dim, const double lo[3], const double hi[3], double spacing,
                          double gamma0);
AbhmParams abhm_init_halton(int dim, const double lo[3], const double hi[3], std::size_t count,
                            double gamma0);

/// Standard-normal noise for one reparameterised draw of every variable (sizes as AbhmParams).
struct AbhmNoise {
  std::vector<double> w, h, g;
  double b = 0.0;
};

/// The negative ELBO estimate for one minibatch and one noise draw, and (if `grad` is not null)
/// its gradient with respect to flat():
///   loss = -scale * sum_{n in batch} log p(y_n | f_n(draw)) + KL(q || prior)
/// `scale` = N / batch size makes the estimate unbiased for the whole data set. CPU, double.
double abhm_loss(const AbhmParams& p, const AbhmPrior& prior, const LabelledPoints& batch,
                 double scale, const AbhmNoise& noise, std::vector<double>* grad);

/// abhm_loss with the sums over samples on the OpenCL device of `ctx`: each sample visits only
/// the kernels of the draw within the cut-off gamma d^2 <= `tau` (default 18), per-kernel
/// gradients are summed over each kernel's samples (no atomics, reproducible). Single precision
/// on the device with positions relative to the batch centre (ABHM areas are small); the KL and
/// the chain rule run on the host in double.
double abhm_loss_device(Context& ctx, const AbhmParams& p, const AbhmPrior& prior,
                        const LabelledPoints& batch, double scale, const AbhmNoise& noise,
                        std::vector<double>* grad, double tau = kDefaultCutoffTau);

/// The KL(q || prior) part of abhm_loss alone (analytic).
double abhm_kl(const AbhmParams& p, const AbhmPrior& prior);

struct AbhmOptions {
  AbhmPrior prior;
  std::size_t steps = 2450;  ///< Adam steps (SPEC default 2450)
  std::size_t batch = 256;   ///< samples per minibatch (drawn without replacement per epoch)
  int mc_samples = 1;        ///< noise draws averaged per step (default 1)
  double lr = 0.01;          ///< Adam step size
  double beta1 = 0.9, beta2 = 0.999, adam_eps = 1e-8;
  std::uint64_t seed = 1;          ///< minibatch order and noise
  std::size_t report_every = 100;  ///< progress callback period in steps (0: never)
  /// Called every report_every steps with the step and the minibatch ELBO estimate (nats).
  std::function<void(std::size_t step, double elbo)> progress;
  /// If not empty: the checkpoint file written every `checkpoint_every` steps and at the end,
  /// and read at the start if it exists (training resumes from its step).
  std::string checkpoint;
  std::size_t checkpoint_every = 500;
  /// Stop after this many steps of this call even if `steps` is not reached (0: no limit);
  /// with a checkpoint, a later call continues.
  std::size_t max_steps_this_call = 0;
  /// Device for the per-sample sums (abhm_loss_device); null (default): the CPU reference.
  Context* device = nullptr;
};

/// Trains `params` in place by SVI with Adam on the CPU. Returns the number of steps done in
/// total (including those of a resumed checkpoint). Throws ArgumentError on bad input and
/// InputError on an unreadable or mismatched checkpoint.
std::size_t abhm_train(AbhmParams& params, const LabelledPoints& data, const AbhmOptions& options);

}  // namespace potmap
POTMAP_CXX_API_END
