// Signatures, nearest-neighbour query and rotation estimates of the indexed ranking (see
// include/potmap/pot/atom_index.hpp).
#include "potmap/pot/atom_index.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numeric>
#include <string>

#include "atom_transport_cache.hpp"
#include "class_ranking.hpp"
#include "potmap/error.hpp"
#include "runtime/wider_vectors.hpp"
#include "thinning.hpp"

namespace potmap {

namespace {

constexpr double kTwoPi = 6.283185307179586;

struct Shape {
  int rings, bins, harmonics;
  double radius;
  const std::complex<double>* phase;  ///< phase_table(): harmonics x bins
};

// The harmonics' phase factors e^(-2 pi i k b / bins), k = 1..harmonics: made once an index, not
// once a signature (a thousand sines and cosines a sector of every scan).
std::vector<std::complex<double>> phase_table(int harmonics, int bins) {
  std::vector<std::complex<double>> phase(static_cast<std::size_t>(harmonics) * bins);
  for (int k = 1; k <= harmonics; ++k)
    for (int b = 0; b < bins; ++b)
      phase[static_cast<std::size_t>(k - 1) * bins + b] = std::polar(1.0, -kTwoPi * k * b / bins);
  return phase;
}

// Outer edge of ring r: rings of equal width up to the sector radius, the last one open.
double ring_edge(const Shape& s, int r) {
  return r + 1 < s.rings ? s.radius * (r + 1) / s.rings : HUGE_VAL;
}

double ring_mid(const Shape& s, int r) {
  const double lo = r == 0 ? 0 : ring_edge(s, r - 1);
  const double hi = r + 1 < s.rings ? ring_edge(s, r) : s.radius;
  return 0.5 * (lo + std::max(hi, lo));
}

int ring_of(const Shape& s, double radius) {
  int r = 0;
  while (r + 1 < s.rings && radius >= ring_edge(s, r)) ++r;
  return r;
}

// Radius-weighted polar histogram of one class, summing to 1, smoothed twice along the angle
// with [1 2 1] / 4. Empty when the class has no samples.
std::vector<float> polar_histogram(const std::vector<double>& pts, int dim, const Shape& s) {
  const std::size_t n = pts.size() / dim;
  if (n == 0) return {};
  std::vector<double> h(static_cast<std::size_t>(s.rings) * s.bins, 0.0);
  double total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double x = pts[i * dim], y = pts[i * dim + 1];
    const double r = std::hypot(x, y);
    double a = std::atan2(y, x);
    if (a < 0) a += kTwoPi;
    int b = static_cast<int>(a / kTwoPi * s.bins);
    b = std::min(std::max(b, 0), s.bins - 1);
    h[static_cast<std::size_t>(ring_of(s, r)) * s.bins + b] += r;
    total += r;
  }
  if (!(total > 0)) {  // every sample at the centre: no angle to speak of, spread it evenly
    std::fill(h.begin(), h.end(), 0.0);
    for (int b = 0; b < s.bins; ++b) h[b] = 1.0 / s.bins;
    total = 1;
  }
  std::vector<double> tmp(s.bins);
  for (int r = 0; r < s.rings; ++r) {
    double* row = &h[static_cast<std::size_t>(r) * s.bins];
    for (int pass = 0; pass < 2; ++pass) {
      for (int b = 0; b < s.bins; ++b)
        tmp[b] =
            0.25 * row[(b + s.bins - 1) % s.bins] + 0.5 * row[b] + 0.25 * row[(b + 1) % s.bins];
      std::copy(tmp.begin(), tmp.end(), row);
    }
  }
  std::vector<float> out(h.size());
  for (std::size_t i = 0; i < h.size(); ++i) out[i] = static_cast<float>(h[i] / total);
  return out;
}

// Radius (and z) quantiles over sqrt(levels), then per ring |F_k| * ring radius, k = 1..harmonics.
std::vector<float> features(const std::array<float, AtomDescriptor::kQuantiles>& radius,
                            const std::array<float, AtomDescriptor::kQuantiles>& z, int dim,
                            const std::vector<float>& polar, const Shape& s) {
  std::vector<float> f;
  const float w = 1.0f / std::sqrt(static_cast<float>(AtomDescriptor::kQuantiles));
  for (float q : radius) f.push_back(q * w);
  if (dim == 3)
    for (float q : z) f.push_back(q * w);
  for (int r = 0; r < s.rings; ++r) {
    const float* row = polar.data() + static_cast<std::size_t>(r) * s.bins;
    for (int k = 1; k <= s.harmonics; ++k) {
      const std::complex<double>* ph = s.phase + static_cast<std::size_t>(k - 1) * s.bins;
      std::complex<double> c = 0;
      for (int b = 0; b < s.bins; ++b) c += double(row[b]) * ph[b];
      f.push_back(static_cast<float>(std::abs(c) * ring_mid(s, r)));
    }
  }
  return f;
}

SectorSignature describe(const Sector& sec, const Shape& s) {
  SectorSignature g;
  g.dim = sec.dim;
  const AtomDescriptor d = describe_sector(sec);
  g.hits = d.hits;
  g.free = d.free;
  g.hit_polar = polar_histogram(sec.hits, sec.dim, s);
  g.free_polar = polar_histogram(sec.free, sec.dim, s);
  if (g.hits) g.hit_features = features(d.hit_radius, d.hit_z, sec.dim, g.hit_polar, s);
  if (g.free) g.free_features = features(d.free_radius, d.free_z, sec.dim, g.free_polar, s);
  return g;
}

double squared_distance(const float* a, const float* b, std::size_t n) {
  float s = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const float d = a[i] - b[i];
    s += d * d;
  }
  return s;
}

}  // namespace

AtomIndex::AtomIndex(const Dictionary& dict, const AtomIndexOptions& o)
    : options_(o), dim_(dict.dim), radius_(dict.max_range * dict.scale) {
  if (o.rings < 1 || o.bins < 8 || o.harmonics < 0 || o.harmonics > o.bins / 2)
    throw ArgumentError("AtomIndex: rings >= 1, bins >= 8 and 0 <= harmonics <= bins / 2, got " +
                        std::to_string(o.rings) + ", " + std::to_string(o.bins) + ", " +
                        std::to_string(o.harmonics));
  if (!(radius_ > 0)) throw ArgumentError("AtomIndex: the dictionary's radius is not positive");
  features_ = static_cast<std::size_t>(AtomDescriptor::kQuantiles * (dim_ == 3 ? 2 : 1) +
                                       o.rings * o.harmonics);
  phase_ = phase_table(o.harmonics, o.bins);
  const std::size_t n = dict.size(), hist = static_cast<std::size_t>(o.rings) * o.bins;
  transport_ = std::make_shared<AtomTransportCache>(n);
  hits_.resize(n);
  free_.resize(n);
  hit_features_.assign(n * features_, 0.f);
  free_features_.assign(n * features_, 0.f);
  hit_polar_.assign(n * hist, 0.f);
  free_polar_.assign(n * hist, 0.f);
  for (std::size_t a = 0; a < n; ++a) {
    const SectorSignature g = signature(dict.atoms[a].sector);
    hits_[a] = g.hits;
    free_[a] = g.free;
    std::copy(g.hit_features.begin(), g.hit_features.end(), &hit_features_[a * features_]);
    std::copy(g.free_features.begin(), g.free_features.end(), &free_features_[a * features_]);
    std::copy(g.hit_polar.begin(), g.hit_polar.end(), &hit_polar_[a * hist]);
    std::copy(g.free_polar.begin(), g.free_polar.end(), &free_polar_[a * hist]);
    const Sector& sec = dict.atoms[a].sector;
    coarse_hits_.push_back(detail::subsample_even(sec.hits, dim_, o.coarse_hits));
    coarse_free_.push_back(detail::subsample_even(sec.free, dim_, o.coarse_free));
  }
}

SectorSignature AtomIndex::signature(const Sector& sector) const {
  if (sector.dim != dim_)
    throw ArgumentError("AtomIndex: a " + std::to_string(sector.dim) + "D sector for a " +
                        std::to_string(dim_) + "D dictionary");
  return describe(sector,
                  Shape{options_.rings, options_.bins, options_.harmonics, radius_, phase_.data()});
}

void AtomIndex::distances(const SectorSignature& t, std::vector<double>& dh,
                          std::vector<double>& df) const {
  if (t.dim != dim_)
    throw ArgumentError("AtomIndex: a " + std::to_string(t.dim) + "D signature for a " +
                        std::to_string(dim_) + "D dictionary");
  const std::size_t n = size();
  dh.assign(n, 0);
  df.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (t.hits)
      dh[i] = hits_[i] ? squared_distance(t.hit_features.data(), &hit_features_[i * features_],
                                          features_)
                       : -1;
    if (t.free)
      df[i] = free_[i] ? squared_distance(t.free_features.data(), &free_features_[i * features_],
                                          features_)
                       : -1;
  }
}

std::vector<std::size_t> AtomIndex::nearest(const SectorSignature& t, std::size_t k) const {
  std::vector<double> dh, df;
  distances(t, dh, df);
  return detail::order_by_class_distance(dh, df, k);
}

std::vector<std::size_t> AtomIndex::farthest(const SectorSignature& t) const {
  std::vector<double> dh, df;
  distances(t, dh, df);
  std::vector<std::size_t> out;
  for (const std::vector<double>* d : {&dh, &df}) {
    const auto it = std::max_element(d->begin(), d->end());
    if (it != d->end() && *it > 0) {
      const std::size_t a = static_cast<std::size_t>(it - d->begin());
      if (std::find(out.begin(), out.end(), a) == out.end()) out.push_back(a);
    }
  }
  return out;
}

POTMAP_WIDER_VECTORS std::vector<RotationEstimate> AtomIndex::rotations(const SectorSignature& t,
                                                                        std::size_t atom,
                                                                        int count) const {
  if (atom >= size()) throw ArgumentError("AtomIndex: no atom " + std::to_string(atom));
  const int B = options_.bins;
  const std::size_t hist = static_cast<std::size_t>(options_.rings) * B;
  // c(k) = sum over classes, rings and bins of atom[b] * target[b + k]: the atom rotated by
  // k bins laid over the target. The target's rows are doubled so that b + k needs no modulo.
  std::vector<double> corr(B, 0.0);
  std::vector<float> twice(2 * B), sum(B);
  auto add = [&](const float* a, const std::vector<float>& tp) {
    for (int r = 0; r < options_.rings; ++r) {
      const float* ar = a + static_cast<std::size_t>(r) * B;
      const float* tr = tp.data() + static_cast<std::size_t>(r) * B;
      std::copy(tr, tr + B, twice.begin());
      std::copy(tr, tr + B, twice.begin() + B);
      // Every shift k at once, bin by bin: each sum[k] adds its terms in bin order (the same
      // float sums as one shift at a time), and the loop over k vectorises.
      std::fill(sum.begin(), sum.end(), 0.0f);
      float* __restrict sk = sum.data();
      for (int b = 0; b < B; ++b) {
        const float ab = ar[b];
        const float* tb = twice.data() + b;
        for (int k = 0; k < B; ++k) sk[k] += ab * tb[k];
      }
      for (int k = 0; k < B; ++k) corr[k] += sum[k];
    }
  };
  if (t.hits && hits_[atom]) add(&hit_polar_[atom * hist], t.hit_polar);
  if (t.free && free_[atom]) add(&free_polar_[atom * hist], t.free_polar);

  // Local maxima, highest first, each at least 45 degrees from those already taken.
  std::vector<int> peaks;
  for (int k = 0; k < B; ++k)
    if (corr[k] >= corr[(k + B - 1) % B] && corr[k] >= corr[(k + 1) % B]) peaks.push_back(k);
  std::sort(peaks.begin(), peaks.end(),
            [&](int a, int b) { return corr[a] != corr[b] ? corr[a] > corr[b] : a < b; });
  std::vector<RotationEstimate> out;
  std::vector<int> taken;
  const int apart = std::max(1, B / 8);
  for (int k : peaks) {
    if (static_cast<int>(out.size()) >= count) break;
    bool far = true;
    for (int j : taken) {
      const int d = std::abs(k - j);
      far = far && std::min(d, B - d) >= apart;
    }
    if (!far) continue;
    taken.push_back(k);
    const double l = corr[(k + B - 1) % B], c = corr[k], r = corr[(k + 1) % B];
    const double den = l - 2 * c + r;
    const double off = den < 0 ? std::clamp(0.5 * (l - r) / den, -0.5, 0.5) : 0.0;
    double a = (k + off) * kTwoPi / B;
    if (a < 0) a += kTwoPi;
    if (a >= kTwoPi) a -= kTwoPi;
    out.push_back({a, c});
  }
  if (out.empty()) out.push_back({0.0, 0.0});
  return out;
}

std::size_t AtomIndex::bytes_per_atom() const {
  const std::size_t hist = static_cast<std::size_t>(options_.rings) * options_.bins;
  std::size_t coarse = 0;
  for (std::size_t a = 0; a < size(); ++a)
    coarse += sizeof(double) * (coarse_hits_[a].size() + coarse_free_[a].size());
  return 2 * sizeof(std::size_t) + 2 * features_ * sizeof(float) + 2 * hist * sizeof(float) +
         2 * sizeof(Eigen::MatrixXd) + (size() ? coarse / size() : 0);
}

}  // namespace potmap
