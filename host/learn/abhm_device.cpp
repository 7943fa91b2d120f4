#include <boost/compute/buffer.hpp>
#include <boost/compute/kernel.hpp>
#include <string>
#include <vector>

#include "abhm_detail.hpp"
#include "bhm_detail.hpp"
#include "pair_buffers.hpp"
#include "potmap/error.hpp"
#include "potmap/learn/abhm.hpp"
#include "runtime/cl_check.hpp"
#include "runtime/device_buffers.hpp"

namespace potmap {

namespace bc = boost::compute;
using detail::from_device;
using detail::round_up;
using detail::to_device;
using detail::upload;

double abhm_loss_device(Context& ctx, const AbhmParams& p, const AbhmPrior& prior,
                        const LabelledPoints& batch, double scale, const AbhmNoise& noise,
                        std::vector<double>* grad, double tau) {
  const std::size_t m = p.size(), n = batch.size();
  const int dim = p.dim;
  if (batch.dim != dim) throw ArgumentError("ABHM: samples and kernels differ in dimension");
  const detail::AbhmDraw draw = detail::abhm_draw(p, noise);
  // The cut-off must follow the draw: positions and widths change every step.
  KernelMap drawn;
  drawn.dim = dim;
  drawn.position = draw.h;
  drawn.gamma = draw.g;
  drawn.w_mean = draw.w;
  drawn.w_var.assign(m, 0.0);
  const detail::SampleKernelPairs pairs = detail::build_pairs(drawn, batch, tau);

  double centre[3] = {0, 0, 0};
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < dim; ++d) centre[d] += batch.position[i * dim + d] / double(n);
  std::vector<float> kpos(m * dim), kg(m), kw(m), spos(n * dim), sy(n);
  for (std::size_t k = 0; k < m; ++k) {
    for (int d = 0; d < dim; ++d) kpos[k * dim + d] = float(draw.h[k * dim + d] - centre[d]);
    kg[k] = float(draw.g[k]);
    kw[k] = float(draw.w[k]);
  }
  for (std::size_t i = 0; i < n; ++i) {
    for (int d = 0; d < dim; ++d)
      spos[i * dim + d] = float(batch.position[i * dim + d] - centre[d]);
    sy[i] = batch.label[i] ? 1.0f : 0.0f;
  }
  std::vector<float> gf(n), ll(n), dw(m), dg(m), dh(m * dim);
  bc::buffer b_kpos = to_device(ctx, kpos, "ABHM: kernel positions"),
             b_kg = to_device(ctx, kg, "ABHM: kernel gammas"),
             b_kw = to_device(ctx, kw, "ABHM: kernel weights"),
             b_spos = to_device(ctx, spos, "ABHM: sample positions"),
             b_sy = to_device(ctx, sy, "ABHM: sample labels"),
             b_gf = to_device(ctx, gf, "ABHM: sample logits"),
             b_ll = to_device(ctx, ll, "ABHM: sample log-likelihoods"),
             b_dw = to_device(ctx, dw, "ABHM: weight gradients"),
             b_dg = to_device(ctx, dg, "ABHM: gamma gradients"),
             b_dh = to_device(ctx, dh, "ABHM: position gradients");
  const detail::PairBuffers pb = detail::upload_pairs(ctx, pairs, "ABHM");
  const std::string defs = "-DDIM=" + std::to_string(dim);
  const std::size_t wg = static_cast<std::size_t>(ctx.tuning().learn.abhm_work_group);
  if (n > 0) {
    KernelLease fwd = ctx.lend_kernel("learn/abhm_grad", "abhm_forward", defs);
    detail::launch_1d(ctx.queue(), *fwd, "abhm_forward", round_up(n, wg), wg, b_kpos, b_kg, b_kw,
                      b_spos, b_sy, pb.sample_start, pb.sample_kernels, static_cast<cl_uint>(n),
                      static_cast<float>(draw.b), static_cast<float>(scale), b_gf, b_ll);
    from_device(ctx, b_ll, ll);
    from_device(ctx, b_gf, gf);
  }
  double loss = 0, db = 0;
  for (std::size_t i = 0; i < n; ++i) {
    loss -= scale * ll[i];
    db += gf[i];
  }
  loss += abhm_kl(p, prior);
  if (!grad) return loss;
  if (m > 0 && n > 0) {
    KernelLease bwd = ctx.lend_kernel("learn/abhm_grad", "abhm_backward", defs);
    detail::launch_1d(ctx.queue(), *bwd, "abhm_backward", round_up(m, wg), wg, b_kpos, b_kg, b_kw,
                      b_spos, b_gf, pb.kernel_start, pb.kernel_samples, static_cast<cl_uint>(m),
                      b_dw, b_dg, b_dh);
    from_device(ctx, b_dw, dw);
    from_device(ctx, b_dg, dg);
    from_device(ctx, b_dh, dh);
  }
  detail::abhm_chain(p, prior, noise, draw.g, std::vector<double>(dw.begin(), dw.end()),
                     std::vector<double>(dh.begin(), dh.end()),
                     std::vector<double>(dg.begin(), dg.end()), db, *grad);
  return loss;
}

}  // namespace potmap
