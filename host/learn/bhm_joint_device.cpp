// JointBhm::update() on the device (kernels/learn/bhm_joint_sums.cl): the host makes the tiles
// a scan reaches and gives each sample its span and tile ids; the device lists the features,
// sorts them into rows (the kernels the scan reaches), and each EM round computes every
// sample's bound and every row's sums there. The host adds the rows' increments to the
// precision, eta and the bias, then solves as update_on_host() does. Each sum is taken in the
// order of the samples, so the result does not depend on how the device schedules its work.
#include "bhm_joint_device.hpp"

#include <cmath>
#include <numeric>

#include "runtime/cl_check.hpp"
#include "runtime/device_buffers.hpp"
#include "runtime/host_team.hpp"

namespace potmap {

namespace bc = boost::compute;
using detail::device_buffer;
using detail::round_up;
using detail::to_device;

namespace detail {

bool sums_on_device(JointBhmSums sums, const DeviceInfo& info) {
  if (!info.has_fp64 || sums == JointBhmSums::host) return false;
  return sums == JointBhmSums::device || info.is_gpu;
}

}  // namespace detail

namespace {

constexpr std::size_t kGroup = 64;
constexpr const char* kProgram = "learn/bhm_joint_sums";

// Exclusive prefix sums of `count`, with the total appended.
std::vector<std::uint32_t> starts_of(const std::vector<std::uint32_t>& count) {
  std::vector<std::uint32_t> start(count.size() + 1, 0);
  std::partial_sum(count.begin(), count.end(), start.begin() + 1);
  return start;
}

}  // namespace

namespace detail {

void JointBhmDevice::list(JointBhm& m, const LabelledPoints& samples, JointDeviceScan& dev) {
  // Spans and tiles on the host (tiles are made in the order of the samples, as on the host
  // path: a throw leaves the model as it was), the features on the device.
  const bool weighted = !samples.weight.empty();
  std::vector<double> pos;
  std::vector<cl_int> span, tiles;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const double* x = &samples.position[i * m.dim_];
    std::int64_t a[3], b[3];
    std::int32_t t[8];
    if (!m.sample_span(x, a, b)) continue;
    m.span_tiles(x, a, b, true, t);
    pos.insert(pos.end(), x, x + m.dim_);
    for (int d = 0; d < 3; ++d) span.push_back(static_cast<cl_int>(a[d]));
    for (int d = 0; d < 3; ++d) span.push_back(static_cast<cl_int>(b[d]));
    tiles.insert(tiles.end(), t, t + 8);
    const double w = weighted ? samples.weight[i] : 1.0;
    dev.w.push_back(w);
    dev.yc.push_back(samples.label[i] ? 0.5 * w : -0.5 * w);
  }
  const std::size_t n = dev.w.size();
  dev.samples = n;
  if (n == 0) return;
  Context& ctx = dev.ctx;
  bc::context& cx = ctx.context();
  bc::command_queue& q = ctx.queue();
  detail::JointGridArgs g{};
  for (int d = 0; d < 3; ++d) g.lo[d] = m.lo_[d];
  g.h = m.o_.spacing;
  g.gamma = m.gamma_;
  g.tau = m.o_.tau;
  g.dim = m.dim_;
  g.tile = static_cast<std::int32_t>(m.tile_);
  g.tile_cells = static_cast<std::int32_t>(m.tile_cells_);
  g.box = static_cast<std::int32_t>(m.box_);
  bc::buffer pos_b = to_device(ctx, pos, "joint BHM: sample positions"),
             span_b = to_device(ctx, span, "joint BHM: sample spans"),
             tiles_b = to_device(ctx, tiles, "joint BHM: sample tiles"),
             count_b = device_buffer(cx, n * 4, "joint BHM: feature counts");
  const auto nu = static_cast<cl_uint>(n);
  {
    KernelLease k = ctx.lend_kernel(kProgram, "joint_count");
    detail::launch_1d(q, *k, "joint_count", round_up(n, kGroup), kGroup, detail::by_value(g), pos_b,
                      span_b, tiles_b, nu, count_b);
  }
  std::vector<std::uint32_t> count(n);
  detail::from_device(q, count_b, count);
  dev.start = starts_of(count);
  dev.has.resize(n);
  for (std::size_t i = 0; i < n; ++i) dev.has[i] = count[i] > 0;
  const std::size_t nf = dev.start.back();
  dev.features = nf;
  if (nf == 0) return;
  dev.start_b = to_device(ctx, dev.start, "joint BHM: feature starts");
  dev.fkernel_b = device_buffer(cx, nf * 4, "joint BHM: feature kernels");
  dev.fphi_b = device_buffer(cx, nf * 8, "joint BHM: feature values");
  dev.flocal_b = device_buffer(cx, nf * 4, "joint BHM: feature cells");
  dev.fsample_b = device_buffer(cx, nf * 4, "joint BHM: feature samples");
  {
    KernelLease k = ctx.lend_kernel(kProgram, "joint_features");
    detail::launch_1d(q, *k, "joint_features", round_up(n, kGroup), kGroup, detail::by_value(g),
                      pos_b, span_b, tiles_b, nu, dev.start_b, dev.fkernel_b, dev.fphi_b,
                      dev.flocal_b, dev.fsample_b);
  }
  m.scratch_.kernel.resize(nf);
  detail::from_device(q, dev.fkernel_b, m.scratch_.kernel);
}

void JointBhmDevice::update(JointBhm& m, const LabelledPoints& samples, Context& ctx) {
  JointBhm::Scratch& sc = m.scratch_;
  JointDeviceScan dev(ctx);
  list(m, samples, dev);
  m.stats_.sums_on_device = true;
  std::size_t n = 0;
  for (std::uint8_t h : dev.has) n += h;
  m.stats_.samples = n;
  if (n == 0) return;
  m.reach_rows(sc);
  // Each feature's row: its kernel's place among the reached ones.
  const std::size_t nrows = sc.reached.size(), nf = dev.features;
  if (sc.row_of.size() < m.mean_.size()) sc.row_of.resize(m.mean_.size());
  for (std::size_t r = 0; r < nrows; ++r) sc.row_of[sc.reached[r]] = static_cast<std::uint32_t>(r);
  std::vector<std::uint32_t> frow(nf);
  for (std::size_t u = 0; u < nf; ++u) frow[u] = sc.row_of[sc.kernel[u]];
  bc::context& cx = ctx.context();
  bc::command_queue& q = ctx.queue();
  dev.frow_b = to_device(ctx, frow, "joint BHM: feature rows");
  const auto nfu = static_cast<cl_uint>(nf), nru = static_cast<cl_uint>(nrows);
  {
    bc::buffer count_b = to_device(ctx, std::vector<cl_uint>(nrows, 0), "joint BHM: row counts");
    KernelLease k = ctx.lend_kernel(kProgram, "joint_row_count");
    detail::launch_1d(q, *k, "joint_row_count", round_up(nf, kGroup), kGroup, dev.frow_b, nfu,
                      count_b);
    std::vector<std::uint32_t> count(nrows);
    detail::from_device(q, count_b, count);
    dev.rstart_b = to_device(ctx, starts_of(count), "joint BHM: row starts");
    bc::buffer fill_b = to_device(ctx, std::vector<cl_uint>(nrows, 0), "joint BHM: row fill");
    dev.rlist_b = device_buffer(cx, nf * 4, "joint BHM: row lists");
    KernelLease place = ctx.lend_kernel(kProgram, "joint_row_place");
    detail::launch_1d(q, *place, "joint_row_place", round_up(nf, kGroup), kGroup, dev.frow_b, nfu,
                      dev.rstart_b, fill_b, dev.rlist_b);
    KernelLease sort = ctx.lend_kernel(kProgram, "joint_row_sort");
    detail::launch_1d(q, *sort, "joint_row_sort", round_up(nrows, kGroup), kGroup, dev.rstart_b,
                      nru, dev.rlist_b);
  }
  dev.w_b = to_device(ctx, dev.w, "joint BHM: sample weights");
  dev.yc_b = to_device(ctx, dev.yc, "joint BHM: sample labels");
  dev.half_at_b = to_device(ctx, m.half_at_, "joint BHM: half stencil slots");
  dev.lambda_b = to_device(ctx, std::vector<double>(dev.samples, 0.0), "joint BHM: lambda");
  dev.c_b = device_buffer(cx, dev.samples * 8, "joint BHM: curvature changes");
  dev.mu_b = device_buffer(cx, dev.samples * 8, "joint BHM: sample means");
  const auto hs = static_cast<std::size_t>(m.half_slots_);
  dev.dprec_b = device_buffer(cx, nrows * hs * 8, "joint BHM: precision increments");
  dev.drow_b = device_buffer(cx, nrows * 3 * 8, "joint BHM: row increments");
  dev.row_mean_b = device_buffer(cx, nrows * 8, "joint BHM: row means");
  dev.row_diag_b = device_buffer(cx, nrows * 8, "joint BHM: row diagonals");
  const double bias_outside = m.prepare_solve(sc);
  const bool boxed = m.box_rows(sc.rows, sc);
  (void)boxed;  // m.solve() reads the box from the scratch
  for (int it = 0; it < m.o_.em_iterations; ++it) {
    apply_round(m, dev, it);
    m.stats_.residual =
        m.solve(sc.rows, m.mean_, m.meanb_, m.o_.cg_tolerance, m.o_.cg_max_iterations,
                &m.stats_.cg_iterations, sc, true, &ctx, &bias_outside, it > 0);
  }
}

void JointBhmDevice::apply_round(JointBhm& m, JointDeviceScan& dev, int round) {
  // One EM round's bound and sums on the device, added here in the host path's order: eta (the
  // first round) and the bias's terms per sample, the rows' increments per row.
  JointBhm::Scratch& sc = m.scratch_;
  Context& ctx = dev.ctx;
  bc::command_queue& q = ctx.queue();
  const std::size_t nrows = sc.reached.size(), n = dev.samples;
  const auto hs = static_cast<std::size_t>(m.half_slots_);
  std::vector<double> row_mean(nrows), row_diag(nrows);
  for (std::size_t r = 0; r < nrows; ++r) {
    row_mean[r] = m.mean_[sc.reached[r]];
    row_diag[r] = m.prec_[std::size_t(sc.reached[r]) * hs];
  }
  detail::upload(ctx, dev.row_mean_b, row_mean, "joint BHM: row means");
  detail::upload(ctx, dev.row_diag_b, row_diag, "joint BHM: row diagonals");
  const double mean_b = m.o_.bias ? m.meanb_ : 0.0, var_b = m.o_.bias ? 1.0 / m.pbb_ : 0.0;
  {
    KernelLease k = ctx.lend_kernel(kProgram, "joint_bound");
    detail::launch_1d(q, *k, "joint_bound", round_up(n, kGroup), kGroup, dev.start_b, dev.frow_b,
                      dev.fphi_b, dev.w_b, static_cast<cl_uint>(n), dev.row_mean_b, dev.row_diag_b,
                      mean_b, var_b, dev.lambda_b, dev.c_b, dev.mu_b);
  }
  {
    KernelLease k = ctx.lend_kernel(kProgram, "joint_rows");
    detail::launch_1d(q, *k, "joint_rows", round_up(nrows, kGroup), kGroup, dev.rstart_b,
                      dev.rlist_b, static_cast<cl_uint>(nrows), dev.start_b, dev.fsample_b,
                      dev.fphi_b, dev.flocal_b, dev.half_at_b, static_cast<cl_int>(m.centre_lin_),
                      static_cast<cl_int>(m.half_slots_), dev.c_b, dev.mu_b, dev.yc_b,
                      static_cast<cl_int>(round == 0), dev.dprec_b, dev.drow_b);
  }
  dev.c.resize(n);
  dev.mu.resize(n);
  dev.dprec.resize(nrows * hs);
  dev.drow.resize(nrows * 3);
  {
    detail::BatchedReads reads(q);
    reads.read(dev.c_b, dev.c);
    reads.read(dev.mu_b, dev.mu);
    reads.read(dev.dprec_b, dev.dprec);
    reads.read(dev.drow_b, dev.drow);
    reads.wait();
  }
  const bool carry = round > 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!dev.has[i]) continue;
    if (round == 0 && m.o_.bias) m.etab_ += dev.yc[i];
    m.pbb_ += dev.c[i];
    if (carry && m.o_.bias) sc.rb -= dev.c[i] * dev.mu[i];
  }
  for (std::size_t r = 0; r < nrows; ++r) {
    const std::size_t k = sc.reached[r];
    double* row = &m.prec_[k * hs];
    const double* d = &dev.dprec[r * hs];
    for (std::size_t t = 0; t < hs; ++t) row[t] += d[t];
    m.bcoup_[k] += dev.drow[3 * r];
    if (carry) sc.r[k] -= dev.drow[3 * r + 1];
    if (round == 0) m.eta_[k] += dev.drow[3 * r + 2];
  }
}

}  // namespace detail
}  // namespace potmap
