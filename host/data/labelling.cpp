#include "potmap/data/labelling.hpp"
#include "beam_samples.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "potmap/error.hpp"

namespace potmap {

namespace data {

SimRng split_rng(std::int64_t scan_index, const LabelOptions& o) {
  SimRng rng{o.seed * 0x2545f4914f6cdd1dULL ^ static_cast<std::uint64_t>(scan_index)};
  rng.next();
  return rng;
}

std::vector<std::uint8_t> draw_split(std::size_t nb, const LabelOptions& o, SimRng& rng) {
  std::vector<std::uint8_t> held(nb, 0);
  const std::size_t nheld = static_cast<std::size_t>(std::lround(o.holdout_fraction * nb));
  if (nheld > 0) {
    std::vector<std::uint32_t> idx(nb);
    std::iota(idx.begin(), idx.end(), 0u);
    for (std::size_t i = 0; i < nheld; ++i) {
      std::swap(idx[i], idx[i + rng.below(nb - i)]);
      held[idx[i]] = 1;
    }
  }
  return held;
}

bool beam_segment(const Scan& scan, std::size_t b, const double* org, double rmax,
                  BeamSegment& out) {
  const int d = scan.dim;
  const std::size_t nh = scan.num_hits();
  if (b < nh) {
    const double* p = &scan.hits[b * d];
    double r2 = 0;
    bool finite = true;
    for (int k = 0; k < d; ++k) {
      finite = finite && std::isfinite(p[k]);
      out.dir[k] = p[k] - org[k];
      r2 += out.dir[k] * out.dir[k];
    }
    if (!finite) return false;
    const double r = std::sqrt(r2);
    out.hit = r < rmax;
    out.len = out.hit ? r : rmax;
    if (r > 0)
      for (int k = 0; k < d; ++k) out.dir[k] /= r;
    if (out.hit) std::copy(p, p + d, out.end);
    return true;
  }
  const double* u = &scan.no_return[(b - nh) * d];
  double n2 = 0;
  for (int k = 0; k < d; ++k) n2 += u[k] * u[k];
  if (!std::isfinite(n2) || n2 == 0 || !std::isfinite(rmax)) return false;
  const double inv = 1 / std::sqrt(n2);
  for (int k = 0; k < d; ++k) out.dir[k] = u[k] * inv;
  out.hit = false;
  out.len = rmax;
  return true;
}

void check_label_options(const LabelOptions& o, const char* who) {
  if (!(o.free_per_metre >= 0) || o.max_free_per_beam < 1 ||
      !(o.holdout_fraction >= 0 && o.holdout_fraction <= 1))
    throw ArgumentError(std::string(who) +
                        ": free_per_metre must be >= 0, holdout_fraction in [0, 1]");
}

long free_samples(double len, const LabelOptions& o) {
  const double want = std::min(len * o.free_per_metre, static_cast<double>(o.max_free_per_beam));
  return std::max(1L, std::lround(want));
}

}  // namespace data

namespace {

using Rng = data::SimRng;
using data::draw_split;
using data::split_rng;

void push(LabelledPoints& lp, const double* p, int d, std::uint8_t y, std::int64_t t) {
  lp.position.insert(lp.position.end(), p, p + d);
  lp.label.push_back(y);
  lp.scan.push_back(t);
}

}  // namespace

std::vector<std::uint8_t> heldout_beams(const Scan& scan, std::int64_t scan_index,
                                        const LabelOptions& o) {
  if (!(o.holdout_fraction >= 0 && o.holdout_fraction <= 1))
    throw ArgumentError("heldout_beams: holdout_fraction must be in [0, 1]");
  Rng rng = split_rng(scan_index, o);
  return draw_split(scan.num_beams(), o, rng);
}

Scan split_beams(const Scan& scan, std::int64_t scan_index, const LabelOptions& o, bool held_out) {
  const std::vector<std::uint8_t> held = heldout_beams(scan, scan_index, o);
  Scan out = scan;
  out.hits.clear();
  out.no_return.clear();
  const int d = scan.dim;
  const std::size_t nh = scan.num_hits();
  for (std::size_t b = 0; b < held.size(); ++b) {
    if (static_cast<bool>(held[b]) != held_out) continue;
    if (b < nh)
      out.hits.insert(out.hits.end(), &scan.hits[b * d], &scan.hits[b * d] + d);
    else
      out.no_return.insert(out.no_return.end(), &scan.no_return[(b - nh) * d],
                           &scan.no_return[(b - nh) * d] + d);
  }
  return out;
}

void label_scan(const Scan& scan, std::int64_t scan_index, const LabelOptions& o,
                LabelledSplit& out) {
  const int d = scan.dim;
  if (d != 2 && d != 3) throw ArgumentError("label_scan: scan dim must be 2 or 3");
  data::check_label_options(o, "label_scan");
  for (LabelledPoints* lp : {&out.train, &out.test}) {
    if (lp->empty()) lp->dim = d;
    if (lp->dim != d) throw ArgumentError("label_scan: output dim differs from the scan's");
  }
  const std::size_t nb = scan.num_beams();
  if (nb == 0) return;
  Rng rng = split_rng(scan_index, o);
  const std::vector<std::uint8_t> held = draw_split(nb, o, rng);
  const auto org = scan.origin();
  const double rmax = scan.max_range > 0 ? scan.max_range : HUGE_VAL;
  double q[3];
  for (std::size_t b = 0; b < nb; ++b) {
    LabelledPoints& dst = held[b] ? out.test : out.train;
    data::BeamSegment beam;
    if (!data::beam_segment(scan, b, org.data(), rmax, beam)) {
      ++out.points_dropped;
      continue;
    }
    if (beam.hit) push(dst, beam.end, d, 1, scan_index);
    const long nfree = data::free_samples(beam.len, o);
    for (long j = 0; j < nfree; ++j) {
      const double s = rng.uniform() * beam.len;
      for (int k = 0; k < d; ++k) q[k] = org[k] + s * beam.dir[k];
      push(dst, q, d, 0, scan_index);
    }
  }
}

LabelledSplit label_scans(const std::vector<Scan>& scans, const LabelOptions& options) {
  LabelledSplit out;
  for (std::size_t i = 0; i < scans.size(); ++i)
    label_scan(scans[i], static_cast<std::int64_t>(i), options, out);
  return out;
}

Scan slice_2d(const Scan& s, double z_min, double z_max) {
  if (s.dim != 3) throw ArgumentError("slice_2d: scan is not 3D");
  Scan o;
  o.dim = 2;
  o.timestamp = s.timestamp;
  o.max_range = s.max_range;
  const auto& T = s.pose3d;
  o.pose2d = {T[3], T[7], std::atan2(T[4], T[0])};
  const double z0 = T[11];
  for (std::size_t i = 0; i + 2 < s.hits.size(); i += 3) {
    const double dz = s.hits[i + 2] - z0;
    if (dz >= z_min && dz <= z_max) {
      o.hits.push_back(s.hits[i]);
      o.hits.push_back(s.hits[i + 1]);
    }
  }
  for (std::size_t i = 0; i + 2 < s.no_return.size(); i += 3) {
    const double h = std::hypot(s.no_return[i], s.no_return[i + 1]);
    // A no-return beam belongs to the band when it stays in it out to max range.
    if (h > 0 && s.no_return[i + 2] * s.max_range >= z_min &&
        s.no_return[i + 2] * s.max_range <= z_max) {
      o.no_return.push_back(s.no_return[i] / h);
      o.no_return.push_back(s.no_return[i + 1] / h);
    }
  }
  return o;
}

Scan limit_range(const Scan& scan, double max_range) {
  if (!(max_range > 0) || (scan.max_range > 0 && scan.max_range <= max_range)) return scan;
  Scan out = scan;
  out.max_range = max_range;
  out.hits.clear();
  const int d = scan.dim;
  const auto o = scan.origin();
  for (std::size_t i = 0; i < scan.num_hits(); ++i) {
    const double* p = &scan.hits[i * d];
    double v[3] = {0, 0, 0}, h2 = 0, n2 = 0;
    for (int k = 0; k < d; ++k) {
      v[k] = p[k] - o[k];
      n2 += v[k] * v[k];
      if (k < 2) h2 += v[k] * v[k];
    }
    // Beyond the range (or no direction to keep): the beam says only "free up to max_range".
    if (h2 < max_range * max_range || !(n2 > 0)) {
      out.hits.insert(out.hits.end(), p, p + d);
      continue;
    }
    if (!std::isfinite(n2)) continue;
    for (int k = 0; k < d; ++k) out.no_return.push_back(v[k] / std::sqrt(n2));
  }
  return out;
}

}  // namespace potmap
