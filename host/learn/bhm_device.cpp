#include <boost/compute/buffer.hpp>
#include <boost/compute/kernel.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "bhm_detail.hpp"
#include "map/split_float.hpp"
#include "pair_buffers.hpp"
#include "potmap/learn/bhm.hpp"
#include "runtime/cl_check.hpp"
#include "runtime/device_buffers.hpp"

namespace potmap {

namespace bc = boost::compute;
using detail::from_device;
using detail::round_up;
using detail::to_device;
using detail::upload;

void bhm_update(Context& ctx, KernelMap& map, const LabelledPoints& samples,
                const BhmOptions& options) {
  detail::check_bhm_inputs(map, samples, options);
  const std::size_t n = samples.size(), m = map.size();
  const int dim = map.dim;
  if (n == 0) return;  // no data: the posterior is the prior
  const detail::SampleKernelPairs pairs = detail::build_pairs(map, samples, options.tau);

  double anchor[3] = {0, 0, 0};
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < dim; ++d) anchor[d] += samples.position[i * dim + d];
  for (int d = 0; d < dim; ++d) anchor[d] = std::round(anchor[d] / double(n));

  std::vector<float> khi(m * dim), klo(m * dim), kg(m), shi(n * dim), slo(n * dim), sy(n);
  for (std::size_t k = 0; k < m; ++k) {
    for (int d = 0; d < dim; ++d)
      detail::split(map.position[k * dim + d] - anchor[d], khi[k * dim + d], klo[k * dim + d]);
    kg[k] = static_cast<float>(map.gamma[k]);
  }
  double bias_y = 0;
  for (std::size_t i = 0; i < n; ++i) {
    for (int d = 0; d < dim; ++d)
      detail::split(samples.position[i * dim + d] - anchor[d], shi[i * dim + d], slo[i * dim + d]);
    sy[i] = samples.label[i] ? 0.5f : -0.5f;
    bias_y += sy[i];
  }
  std::vector<float> lambda(n, static_cast<float>(detail::jj_lambda(options.xi_init)));
  std::vector<float> a(m), b(m), wm(m), wv(m);

  bc::buffer b_khi = to_device(ctx, khi, "BHM: kernel positions (hi)"),
             b_klo = to_device(ctx, klo, "BHM: kernel positions (lo)"),
             b_kg = to_device(ctx, kg, "BHM: kernel gammas"),
             b_shi = to_device(ctx, shi, "BHM: sample positions (hi)"),
             b_slo = to_device(ctx, slo, "BHM: sample positions (lo)"),
             b_sy = to_device(ctx, sy, "BHM: sample labels"),
             b_lambda = to_device(ctx, lambda, "BHM: sample lambdas"),
             b_a = to_device(ctx, a, "BHM: precision a"),
             b_b = to_device(ctx, b, "BHM: precision b"),
             b_wm = to_device(ctx, wm, "BHM: weight means"),
             b_wv = to_device(ctx, wv, "BHM: weight variances");

  const detail::PairBuffers pb = detail::upload_pairs(ctx, pairs, "BHM");
  const std::string defs = "-DDIM=" + std::to_string(dim);
  KernelLease acc_lease = ctx.lend_kernel("learn/bhm_update", "bhm_accumulate", defs);
  KernelLease lam_lease = ctx.lend_kernel("learn/bhm_update", "bhm_lambda", defs);
  bc::kernel &acc = *acc_lease, &lam = *lam_lease;
  const std::size_t wg = static_cast<std::size_t>(ctx.tuning().learn.bhm_work_group);

  const std::vector<double> mean0 = map.w_mean, var0 = map.w_var;
  const double bmean0 = map.bias_mean, bvar0 = map.bias_var;
  std::vector<double> ad(m), bd(m);
  for (int it = 0; it < options.em_iterations; ++it) {
    if (m > 0) {
      detail::launch_1d(ctx.queue(), acc, "bhm_accumulate", round_up(m, wg), wg, b_khi, b_klo, b_kg,
                        b_shi, b_slo, b_sy, b_lambda, pb.kernel_start, pb.kernel_samples,
                        static_cast<cl_uint>(m), b_a, b_b);
      from_device(ctx, b_a, a);
      from_device(ctx, b_b, b);
    }
    double bias_lambda = 0;
    for (float l : lambda) bias_lambda += l;
    for (std::size_t k = 0; k < m; ++k) {
      ad[k] = a[k];
      bd[k] = b[k];
    }
    detail::bhm_posterior(map, mean0, var0, ad.data(), bd.data(), bias_lambda, bias_y, bmean0,
                          bvar0);
    if (it + 1 == options.em_iterations) break;
    for (std::size_t k = 0; k < m; ++k) {
      wm[k] = static_cast<float>(map.w_mean[k]);
      wv[k] = static_cast<float>(map.w_var[k]);
    }
    upload(ctx, b_wm, wm, "BHM: weight means");
    upload(ctx, b_wv, wv, "BHM: weight variances");
    detail::launch_1d(ctx.queue(), lam, "bhm_lambda", round_up(n, wg), wg, b_khi, b_klo, b_kg, b_wm,
                      b_wv, b_shi, b_slo, pb.sample_start, pb.sample_kernels,
                      static_cast<cl_uint>(n),
                      static_cast<float>(map.has_bias ? map.bias_mean : 0.0),
                      static_cast<float>(map.has_bias ? map.bias_var : 0.0), b_lambda);
    from_device(ctx, b_lambda, lambda);
  }
}

}  // namespace potmap
