#pragma once
// Pieces shared by the BHM reference and device paths.

#include <cstdint>
#include <vector>

#include "potmap/learn/bhm.hpp"

namespace potmap::detail {

/// The Jaakkola-Jordan lambda(xi) = (sigmoid(xi) - 1/2) / (2 xi), even in xi, 1/8 at 0.
double jj_lambda(double xi);

void check_bhm_inputs(const KernelMap& map, const LabelledPoints& samples,
                      const BhmOptions& options);

/// The (sample, kernel) pairs within the cut-off, as CSR both ways.
struct SampleKernelPairs {
  std::vector<std::uint32_t> sample_start, sample_kernels;  // per sample: its kernels
  std::vector<std::uint32_t> kernel_start, kernel_samples;  // per kernel: its samples
};
SampleKernelPairs build_pairs(const KernelMap& map, const LabelledPoints& samples, double tau);

/// phi = exp(-gamma |x - h|^2) of every pair, in the per-sample order of `pairs`.
std::vector<double> pair_features(const KernelMap& map, const LabelledPoints& samples,
                                  const SampleKernelPairs& pairs);

/// E-step posterior from the prior and the two sums over samples (per kernel and for the bias).
void bhm_posterior(KernelMap& map, const std::vector<double>& prior_mean,
                   const std::vector<double>& prior_var, const double* sum_lambda_phi2,
                   const double* sum_y_phi, double bias_lambda, double bias_y, double bias_mean0,
                   double bias_var0);

}  // namespace potmap::detail
