#include "potmap/learn/abhm.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <numeric>
#include <random>

#include "abhm_detail.hpp"
#include "io/container.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace {

double softplus(double s) {
  return s > 30 ? s : std::log1p(std::exp(s));
}
double sigmoid(double s) {
  return 1.0 / (1.0 + std::exp(-s));
}
double inv_softplus(double v) {
  return v > 30 ? v : std::log(std::expm1(v));
}
// log(1 + e^f) without overflow.
double log1pexp(double f) {
  return f > 0 ? f + std::log1p(std::exp(-f)) : std::log1p(std::exp(f));
}

const double kHalfLog2Pi = 0.5 * std::log(2.0 * M_PI);

// KL(N(l, s^2) || N(m0, s0^2)) and its derivatives in l and s.
double kl_normal(double l, double s, double m0, double s0, double& dl, double& ds) {
  const double v0 = s0 * s0;
  dl = (l - m0) / v0;
  ds = -1.0 / s + s / v0;
  return std::log(s0 / s) + (s * s + (l - m0) * (l - m0)) / (2 * v0) - 0.5;
}

// KL(LogNormal(mu, s) || Gamma(a, rate b)) and its derivatives in mu and s.
double kl_lognormal_gamma(double mu, double s, double a, double b, double& dmu, double& ds) {
  const double e = std::exp(mu + 0.5 * s * s);
  const double entropy = mu + 0.5 + std::log(s) + kHalfLog2Pi;
  const double elogp = a * std::log(b) - std::lgamma(a) + (a - 1) * mu - b * e;
  dmu = -a + b * e;
  ds = -1.0 / s + b * e * s;
  return -entropy - elogp;
}

void check_params(const AbhmParams& p) {
  const std::size_t m = p.size();
  if (p.dim != 2 && p.dim != 3) throw ArgumentError("ABHM: dimension must be 2 or 3");
  if (p.w_s.size() != m || p.g_loc.size() != m || p.g_s.size() != m ||
      p.h_loc.size() != m * p.dim || p.h_s.size() != m * p.dim || p.h_grid.size() != m * p.dim)
    throw ArgumentError("ABHM: parameter array sizes disagree");
}

AbhmParams init_at(int dim, std::vector<double> pos, double spacing, double gamma0) {
  if (!(gamma0 > 0)) throw ArgumentError("ABHM: gamma0 must be positive");
  AbhmParams p;
  p.dim = dim;
  const std::size_t m = pos.size() / dim;
  p.h_grid = pos;
  p.h_loc = pos;
  p.h_s.assign(m * dim, inv_softplus(0.01 * spacing));
  p.w_loc.assign(m, 0.0);
  p.w_s.assign(m, inv_softplus(0.1));
  p.g_loc.assign(m, std::log(gamma0));
  p.g_s.assign(m, inv_softplus(0.1));
  p.b_loc = 0;
  p.b_s = inv_softplus(0.1);
  return p;
}

double halton(std::size_t i, int base) {
  double f = 1, r = 0;
  for (; i > 0; i /= base) {
    f /= base;
    r += f * (i % base);
  }
  return r;
}

}  // namespace

std::vector<double> AbhmParams::flat() const {
  std::vector<double> v;
  v.reserve(size() * (4 + 2 * dim) + 2);
  for (const auto* a : {&w_loc, &w_s, &h_loc, &h_s, &g_loc, &g_s})
    v.insert(v.end(), a->begin(), a->end());
  v.push_back(b_loc);
  v.push_back(b_s);
  return v;
}

void AbhmParams::set_flat(const std::vector<double>& v) {
  if (v.size() != size() * (4 + 2 * dim) + 2) throw ArgumentError("ABHM: flat size mismatch");
  auto it = v.begin();
  for (auto* a : {&w_loc, &w_s, &h_loc, &h_s, &g_loc, &g_s}) {
    std::copy(it, it + a->size(), a->begin());
    it += a->size();
  }
  b_loc = *it++;
  b_s = *it;
}

KernelMap AbhmParams::to_map(bool mean_gamma) const {
  check_params(*this);
  KernelMap map;
  map.dim = dim;
  map.position = h_loc;
  for (std::size_t k = 0; k < size(); ++k) {
    const double sg = softplus(g_s[k]);
    map.gamma.push_back(std::exp(g_loc[k] + (mean_gamma ? 0.5 * sg * sg : 0.0)));
    map.w_mean.push_back(w_loc[k]);
    map.w_var.push_back(softplus(w_s[k]) * softplus(w_s[k]));
  }
  map.has_bias = true;
  map.bias_mean = b_loc;
  map.bias_var = softplus(b_s) * softplus(b_s);
  return map;
}

AbhmParams abhm_init_grid(int dim, const double lo[3], const double hi[3], double spacing,
                          double gamma0) {
  if (dim != 2 && dim != 3) throw ArgumentError("ABHM: dimension must be 2 or 3");
  if (!(spacing > 0)) throw ArgumentError("ABHM: spacing must be positive");
  std::int64_t n[3] = {1, 1, 1};
  for (int d = 0; d < dim; ++d) {
    if (!(hi[d] >= lo[d])) throw ArgumentError("ABHM: bounds must satisfy lo <= hi");
    n[d] = static_cast<std::int64_t>(std::floor((hi[d] - lo[d]) / spacing + 1e-9)) + 1;
  }
  std::vector<double> pos;
  for (std::int64_t k = 0; k < n[2]; ++k)
    for (std::int64_t j = 0; j < n[1]; ++j)
      for (std::int64_t i = 0; i < n[0]; ++i) {
        const double p[3] = {lo[0] + i * spacing, lo[1] + j * spacing, lo[2] + k * spacing};
        pos.insert(pos.end(), p, p + dim);
      }
  return init_at(dim, std::move(pos), spacing, gamma0);
}

AbhmParams abhm_init_halton(int dim, const double lo[3], const double hi[3], std::size_t count,
                            double gamma0) {
  if (dim != 2 && dim != 3) throw ArgumentError("ABHM: dimension must be 2 or 3");
  if (count == 0) throw ArgumentError("ABHM: kernel count must be positive");
  const int bases[3] = {2, 3, 5};
  std::vector<double> pos;
  double vol = 1;
  for (int d = 0; d < dim; ++d) vol *= std::max(hi[d] - lo[d], 1e-9);
  // Index from 1: the Halton point 0 is the corner of every axis at once.
  for (std::size_t i = 1; i <= count; ++i)
    for (int d = 0; d < dim; ++d) pos.push_back(lo[d] + (hi[d] - lo[d]) * halton(i, bases[d]));
  return init_at(dim, std::move(pos), std::pow(vol / double(count), 1.0 / dim), gamma0);
}

double abhm_kl(const AbhmParams& p, const AbhmPrior& prior) {
  double kl = 0, a, b;
  for (std::size_t k = 0; k < p.size(); ++k) {
    kl += kl_normal(p.w_loc[k], softplus(p.w_s[k]), 0.0, prior.w_sd, a, b);
    kl += kl_lognormal_gamma(p.g_loc[k], softplus(p.g_s[k]), prior.g_shape, prior.g_rate, a, b);
  }
  for (std::size_t j = 0; j < p.h_loc.size(); ++j)
    kl += kl_normal(p.h_loc[j], softplus(p.h_s[j]), p.h_grid[j], prior.h_sd, a, b);
  kl += kl_normal(p.b_loc, softplus(p.b_s), 0.0, prior.w_sd, a, b);
  return kl;
}

double abhm_loss(const AbhmParams& p, const AbhmPrior& prior, const LabelledPoints& batch,
                 double scale, const AbhmNoise& noise, std::vector<double>* grad) {
  check_params(p);
  const std::size_t m = p.size();
  const int dim = p.dim;
  if (batch.dim != dim) throw ArgumentError("ABHM: samples and kernels differ in dimension");
  // The reparameterised draw.
  std::vector<double> w(m), h(m * dim), g(m);
  for (std::size_t k = 0; k < m; ++k) {
    w[k] = p.w_loc[k] + softplus(p.w_s[k]) * noise.w[k];
    g[k] = std::exp(p.g_loc[k] + softplus(p.g_s[k]) * noise.g[k]);
  }
  for (std::size_t j = 0; j < m * dim; ++j) h[j] = p.h_loc[j] + softplus(p.h_s[j]) * noise.h[j];
  const double bias = p.b_loc + softplus(p.b_s) * noise.b;

  std::vector<double> dw(m, 0.0), dh(m * dim, 0.0), dg(m, 0.0), phi(m), d2(m);
  double db = 0, loss = 0;
  for (std::size_t n = 0; n < batch.size(); ++n) {
    const double* x = &batch.position[n * dim];
    double f = bias;
    for (std::size_t k = 0; k < m; ++k) {
      double s = 0;
      for (int d = 0; d < dim; ++d) s += (x[d] - h[k * dim + d]) * (x[d] - h[k * dim + d]);
      d2[k] = s;
      phi[k] = std::exp(-g[k] * s);
      f += w[k] * phi[k];
    }
    const double y = batch.label[n] ? 1.0 : 0.0;
    loss -= scale * (y * f - log1pexp(f));
    if (!grad) continue;
    const double gf = -scale * (y - sigmoid(f));  // d loss / d f
    db += gf;
    for (std::size_t k = 0; k < m; ++k) {
      const double t = gf * phi[k];
      dw[k] += t;
      dg[k] -= t * w[k] * d2[k];
      for (int d = 0; d < dim; ++d)
        dh[k * dim + d] += 2.0 * t * g[k] * w[k] * (x[d] - h[k * dim + d]);
    }
  }
  loss += abhm_kl(p, prior);
  if (grad) detail::abhm_chain(p, prior, noise, g, dw, dh, dg, db, *grad);
  return loss;
}

namespace detail {

AbhmDraw abhm_draw(const AbhmParams& p, const AbhmNoise& noise) {
  const std::size_t m = p.size();
  AbhmDraw d;
  d.w.resize(m);
  d.g.resize(m);
  d.h.resize(m * p.dim);
  for (std::size_t k = 0; k < m; ++k) {
    d.w[k] = p.w_loc[k] + softplus(p.w_s[k]) * noise.w[k];
    d.g[k] = std::exp(p.g_loc[k] + softplus(p.g_s[k]) * noise.g[k]);
  }
  for (std::size_t j = 0; j < m * p.dim; ++j) d.h[j] = p.h_loc[j] + softplus(p.h_s[j]) * noise.h[j];
  d.b = p.b_loc + softplus(p.b_s) * noise.b;
  return d;
}

void abhm_chain(const AbhmParams& p, const AbhmPrior& prior, const AbhmNoise& noise,
                const std::vector<double>& g, const std::vector<double>& dw,
                const std::vector<double>& dh, const std::vector<double>& dg, double db,
                std::vector<double>& grad) {
  const std::size_t m = p.size();
  const std::size_t md = m * p.dim;
  grad.assign(4 * m + 2 * md + 2, 0.0);
  double* gw_loc = grad.data();
  double* gw_s = gw_loc + m;
  double* gh_loc = gw_s + m;
  double* gh_s = gh_loc + md;
  double* gg_loc = gh_s + md;
  double* gg_s = gg_loc + m;
  double a, b;
  for (std::size_t k = 0; k < m; ++k) {
    const double sw = softplus(p.w_s[k]), sg = softplus(p.g_s[k]);
    kl_normal(p.w_loc[k], sw, 0.0, prior.w_sd, a, b);
    gw_loc[k] = dw[k] + a;
    gw_s[k] = (dw[k] * noise.w[k] + b) * sigmoid(p.w_s[k]);
    const double dlogg = dg[k] * g[k];  // d loss / d log gamma
    kl_lognormal_gamma(p.g_loc[k], sg, prior.g_shape, prior.g_rate, a, b);
    gg_loc[k] = dlogg + a;
    gg_s[k] = (dlogg * noise.g[k] + b) * sigmoid(p.g_s[k]);
  }
  for (std::size_t j = 0; j < md; ++j) {
    kl_normal(p.h_loc[j], softplus(p.h_s[j]), p.h_grid[j], prior.h_sd, a, b);
    gh_loc[j] = dh[j] + a;
    gh_s[j] = (dh[j] * noise.h[j] + b) * sigmoid(p.h_s[j]);
  }
  kl_normal(p.b_loc, softplus(p.b_s), 0.0, prior.w_sd, a, b);
  grad[4 * m + 2 * md] = db + a;
  grad[4 * m + 2 * md + 1] = (db * noise.b + b) * sigmoid(p.b_s);
}

}  // namespace detail

namespace {

// Checkpoints and parameter files are containers (io/container.hpp) of one layout:
//   offset 12  u32  dim          offset 16  u64  kernel count M
//   offset 24  u64  file size    (checkpoint: offset 32  u64  Adam step)
// then h_grid (M * dim doubles), flat() and, in a checkpoint, Adam's m and v (flat() size each).
constexpr std::uint32_t kAbhmFormatVersion = 2;  // 1: raw host-order files without a checksum
constexpr detail::ContainerLayout kCheckpointLayout{"POTABC\r\n", "an ABHM checkpoint",
                                                    kAbhmFormatVersion, 40, 24};
constexpr detail::ContainerLayout kParamsLayout{"POTABP\r\n", "an ABHM parameter file",
                                                kAbhmFormatVersion, 32, 24};

struct AdamState {
  std::uint64_t step = 0;
  std::vector<double> m, v;
};

std::size_t flat_size(int dim, std::size_t m) {
  return m * (4 + 2 * dim) + 2;
}

// `s` null: a parameter file.
void write_abhm_file(const std::string& path, const AbhmParams& p, const AdamState* s) {
  const detail::ContainerLayout& layout = s ? kCheckpointLayout : kParamsLayout;
  const std::vector<double> th = p.flat();
  detail::ContainerWriter out(
      layout, layout.header_bytes + 8 * (p.h_grid.size() + th.size() * (s ? 3 : 1)) + 4);
  out.u32(static_cast<std::uint32_t>(p.dim));
  out.u64(p.size());
  out.u64(0);  // the file size: filled in by finish()
  if (s) out.u64(s->step);
  out.f64s(p.h_grid);
  out.f64s(th);
  if (s) {
    out.f64s(s->m);
    out.f64s(s->v);
  }
  out.finish(path);
}

// Checks the container and the header (dim 2 or 3, a count that matches the file size) and
// returns the offset of the payload.
std::size_t open_abhm_file(const detail::ContainerReader& r, bool checkpoint) {
  const std::uint32_t dim = r.u32(12);
  if (dim != 2 && dim != 3) r.fail(12, "dimension " + std::to_string(dim) + " (must be 2 or 3)");
  r.check_size(r.u64(24), 24, "the header gives a file size of");
  const std::uint64_t m = r.u64(16);
  const std::size_t header =
      checkpoint ? kCheckpointLayout.header_bytes : kParamsLayout.header_bytes;
  const std::uint64_t expected =
      m <= (std::uint64_t(1) << 32)
          ? header + 8 * (m * dim + flat_size(dim, m) * (checkpoint ? 3 : 1)) + 4
          : 0;
  r.check_size(
      expected, 16,
      "kernel count " + std::to_string(m) + " in " + std::to_string(dim) + "D needs a file of");
  r.check_checksum();
  return header;
}

void read_doubles(const detail::ContainerReader& r, std::size_t& at, std::vector<double>& v) {
  for (double& x : v) {
    x = r.f64(at);
    at += 8;
  }
}

void write_checkpoint(const std::string& path, const AbhmParams& p, const AdamState& s) {
  write_abhm_file(path, p, &s);
}

bool read_checkpoint(const std::string& path, AbhmParams& p, AdamState& s) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return false;
  const detail::ContainerReader r(path, kCheckpointLayout);
  std::size_t at = open_abhm_file(r, true);
  const std::uint64_t dim = r.u32(12), m = r.u64(16);
  if (dim != static_cast<std::uint64_t>(p.dim) || m != p.size())
    r.fail(12, "checkpoint is for " + std::to_string(m) + " kernels in " + std::to_string(dim) +
                   "D, the model has " + std::to_string(p.size()) + " in " + std::to_string(p.dim) +
                   "D");
  std::vector<double> grid(p.h_grid.size()), th(flat_size(p.dim, p.size()));
  s.m.assign(th.size(), 0);
  s.v.assign(th.size(), 0);
  for (auto* v : {&grid, &th, &s.m, &s.v}) read_doubles(r, at, *v);
  p.h_grid = grid;
  p.set_flat(th);
  s.step = r.u64(32);
  return true;
}

}  // namespace

void write_abhm_params(const AbhmParams& p, const std::string& path) {
  check_params(p);
  write_abhm_file(path, p, nullptr);
}

AbhmParams read_abhm_params(const std::string& path) {
  const detail::ContainerReader r(path, kParamsLayout);
  std::size_t at = open_abhm_file(r, false);
  AbhmParams p;
  p.dim = static_cast<int>(r.u32(12));
  const std::size_t m = static_cast<std::size_t>(r.u64(16));
  p.h_grid.resize(m * p.dim);
  p.w_loc.resize(m);
  p.w_s.resize(m);
  p.g_loc.resize(m);
  p.g_s.resize(m);
  p.h_loc.resize(m * p.dim);
  p.h_s.resize(m * p.dim);
  std::vector<double> th(flat_size(p.dim, m));
  read_doubles(r, at, p.h_grid);
  read_doubles(r, at, th);
  p.set_flat(th);
  return p;
}

std::size_t abhm_train(AbhmParams& params, const LabelledPoints& data, const AbhmOptions& o) {
  check_params(params);
  if (data.dim != params.dim) throw ArgumentError("ABHM: data and kernels differ in dimension");
  if (data.empty()) throw ArgumentError("ABHM: no training samples");
  if (o.batch == 0 || o.mc_samples < 1) throw ArgumentError("ABHM: batch and mc_samples >= 1");
  AdamState st;
  std::vector<double> theta = params.flat();
  st.m.assign(theta.size(), 0.0);
  st.v.assign(theta.size(), 0.0);
  if (!o.checkpoint.empty() && read_checkpoint(o.checkpoint, params, st)) theta = params.flat();

  // The random stream depends only on the seed and the step, so a resumed run continues exactly
  // as an uninterrupted one would.
  const std::size_t n = data.size(), bsize = std::min(o.batch, n);
  const double scale = double(n) / double(bsize);
  std::vector<std::size_t> order(n);
  LabelledPoints batch;
  batch.dim = data.dim;
  AbhmNoise noise;
  std::vector<double> grad, gsum;
  std::size_t done_this_call = 0;
  while (st.step < o.steps) {
    if (o.max_steps_this_call && done_this_call >= o.max_steps_this_call) break;
    std::mt19937_64 rng(o.seed * 0x9E3779B97F4A7C15ull + st.step);
    // Minibatch: a random subset (a partial Fisher-Yates shuffle).
    std::iota(order.begin(), order.end(), 0);
    batch.position.clear();
    batch.label.clear();
    for (std::size_t i = 0; i < bsize; ++i) {
      std::swap(order[i], order[i + rng() % (n - i)]);
      const std::size_t j = order[i];
      batch.position.insert(batch.position.end(), &data.position[j * data.dim],
                            &data.position[j * data.dim] + data.dim);
      batch.label.push_back(data.label[j]);
    }
    std::normal_distribution<double> normal;
    gsum.assign(theta.size(), 0.0);
    double loss = 0;
    for (int s = 0; s < o.mc_samples; ++s) {
      noise.w.resize(params.size());
      noise.g.resize(params.size());
      noise.h.resize(params.h_loc.size());
      for (double& e : noise.w) e = normal(rng);
      for (double& e : noise.h) e = normal(rng);
      for (double& e : noise.g) e = normal(rng);
      noise.b = normal(rng);
      loss += (o.device ? abhm_loss_device(*o.device, params, o.prior, batch, scale, noise, &grad)
                        : abhm_loss(params, o.prior, batch, scale, noise, &grad)) /
              o.mc_samples;
      for (std::size_t i = 0; i < grad.size(); ++i) gsum[i] += grad[i] / o.mc_samples;
    }
    ++st.step;
    ++done_this_call;
    const double c1 = 1 - std::pow(o.beta1, double(st.step));
    const double c2 = 1 - std::pow(o.beta2, double(st.step));
    for (std::size_t i = 0; i < theta.size(); ++i) {
      st.m[i] = o.beta1 * st.m[i] + (1 - o.beta1) * gsum[i];
      st.v[i] = o.beta2 * st.v[i] + (1 - o.beta2) * gsum[i] * gsum[i];
      theta[i] -= o.lr * (st.m[i] / c1) / (std::sqrt(st.v[i] / c2) + o.adam_eps);
    }
    params.set_flat(theta);
    if (o.progress && o.report_every && st.step % o.report_every == 0) o.progress(st.step, -loss);
    if (!o.checkpoint.empty() && o.checkpoint_every && st.step % o.checkpoint_every == 0)
      write_checkpoint(o.checkpoint, params, st);
  }
  if (!o.checkpoint.empty()) write_checkpoint(o.checkpoint, params, st);
  return st.step;
}

}  // namespace potmap
