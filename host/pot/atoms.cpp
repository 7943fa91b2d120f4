#include "potmap/pot/atoms.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <unordered_set>

#include "map/kernel_index.hpp"
#include "point_proximity.hpp"
#include "potmap/error.hpp"
#include "thinning.hpp"

namespace potmap {

namespace {

constexpr double kTwoPi = 6.283185307179586476925286766559;

// Sector of a point seen from the sensor, or -1 beyond the radius. The bearing is measured
// counter-clockwise from the heading and wrapped into [0, 2 pi).
int sector_of(const double* p, const std::array<double, 3>& sensor, double heading, double r2max,
              int sectors) {
  const double dx = p[0] - sensor[0], dy = p[1] - sensor[1];
  if (dx * dx + dy * dy > r2max) return -1;
  double a = std::atan2(dy, dx) - heading;
  a -= kTwoPi * std::floor(a / kTwoPi);
  int k = static_cast<int>(a * sectors / kTwoPi);
  return k >= sectors ? sectors - 1 : k;  // a rounding to exactly 2 pi belongs to the last one
}

void check_options(const SectorOptions& o, double max_range, const char* who) {
  if (o.sectors < 1)
    throw ArgumentError(std::string(who) + ": sectors must be >= 1, got " +
                        std::to_string(o.sectors));
  if (!(max_range > 0) || !std::isfinite(max_range))
    throw ArgumentError(std::string(who) + ": max_range must be a positive number of metres, got " +
                        std::to_string(max_range));
  if (!(o.scale > 0) || !std::isfinite(o.scale))
    throw ArgumentError(std::string(who) + ": scale must be positive, got " +
                        std::to_string(o.scale));
}

// One point per occupied cell of edge `cell` (the first in input order), dim per point.
std::vector<double> thin_to_cells(const std::vector<double>& pts, int dim, double cell) {
  std::vector<double> out;
  for (std::size_t i : detail::thin_to_cells(pts, dim, cell))
    out.insert(out.end(), &pts[i * dim], &pts[i * dim] + dim);
  return out;
}

// The atom's kernels at its own (thinned) samples, weighted so that the atom alone reproduces
// the map's logit mean and variance there (see DictionaryOptions::kernels_at_samples).
void anchored_kernels(const KernelMap& map, const detail::KernelIndex& index, const Sector& s,
                      const DictionaryOptions& o, KernelMap& out) {
  const int d = map.dim;
  const double cell = o.kernels_at_samples * s.scale;
  std::vector<double> anchors = thin_to_cells(s.hits, d, cell);
  const std::size_t n_hits = anchors.size() / d;
  const std::vector<double> frees = thin_to_cells(s.free, d, cell);
  anchors.insert(anchors.end(), frees.begin(), frees.end());
  const std::size_t n = anchors.size() / d;
  std::vector<double> mu, s2, gamma, keep_pos;
  std::vector<std::uint8_t> is_hit;
  std::vector<std::uint32_t> near;
  for (std::size_t i = 0; i < n; ++i) {
    double x[3] = {0, 0, 0};
    for (int c = 0; c < d; ++c) x[c] = anchors[i * d + c] / s.scale + s.centre[c];
    const detail::LocalSums ls = detail::local_sums(map, index, x, near);
    // Nothing learned reaches the sample (or only prior-like kernels): it carries no shape.
    if (ls.empty() || !(ls.s2 / ls.sum2 <= o.max_weight_variance)) continue;
    // The map's bias is part of its logit there; atoms carry no bias, so their kernels take it.
    const double m = ls.mu + (map.has_bias ? map.bias_mean : 0.0);
    const double v = ls.s2 + (map.has_bias ? map.bias_var : 0.0), g = ls.nearest_gamma;
    mu.push_back(m);
    s2.push_back(v);
    gamma.push_back(g);
    is_hit.push_back(i < n_hits);
    keep_pos.insert(keep_pos.end(), &anchors[i * d], &anchors[i * d] + d);
  }
  const std::size_t k = mu.size();
  for (std::size_t i = 0; i < k; ++i) {
    // Partition over the atom's own kernels of the same kind (hits or free samples), in
    // metres: each kind alone reproduces the map at its samples, since the two travel by
    // different plans.
    double sum = 0, sum2 = 0;
    for (std::size_t j = 0; j < k; ++j) {
      if (is_hit[j] != is_hit[i]) continue;
      double d2 = 0;
      for (int c = 0; c < d; ++c) {
        const double t = (keep_pos[i * d + c] - keep_pos[j * d + c]) / s.scale;
        d2 += t * t;
      }
      const double phi = std::exp(-gamma[j] * d2);
      sum += phi;
      sum2 += phi * phi;
    }
    out.push_back(&keep_pos[i * d], gamma[i], mu[i] / sum, s2[i] / sum2);
  }
}

}  // namespace

double scan_heading(const Scan& scan) {
  if (scan.dim == 2) return scan.pose2d[2];
  // The sensor's x axis in the world is the first column of R (row-major 3 x 4).
  return std::atan2(scan.pose3d[4], scan.pose3d[0]);
}

std::vector<Sector> cut_sectors(const LabelledPoints& samples, const std::array<double, 3>& sensor,
                                double heading, const SectorOptions& o) {
  check_options(o, o.max_range, "cut_sectors");
  const int d = samples.dim;
  if (d != 2 && d != 3) throw ArgumentError("cut_sectors: samples must be 2D or 3D");
  if (!std::isfinite(heading)) throw ArgumentError("cut_sectors: heading is not finite");
  const std::size_t n = samples.size();
  const double r2max = o.max_range * o.max_range;

  std::vector<int> which(n);
  std::vector<std::size_t> hits(o.sectors, 0), frees(o.sectors, 0);
  std::vector<std::array<double, 3>> hsum(o.sectors, {0, 0, 0}), fsum(o.sectors, {0, 0, 0});
  for (std::size_t i = 0; i < n; ++i) {
    const double* p = &samples.position[i * d];
    const int k = sector_of(p, sensor, heading, r2max, o.sectors);
    which[i] = k;
    if (k < 0) continue;
    auto& sum = samples.label[i] ? hsum[k] : fsum[k];
    ++(samples.label[i] ? hits[k] : frees[k]);
    for (int c = 0; c < d; ++c) sum[c] += p[c];
  }

  std::vector<Sector> out;
  std::vector<int> slot(o.sectors, -1);
  for (int k = 0; k < o.sectors; ++k) {
    if (hits[k] + frees[k] < o.min_samples || hits[k] + frees[k] == 0) continue;
    Sector s;
    s.dim = d;
    s.index = k;
    s.sensor = sensor;
    s.scale = o.scale;
    s.max_range = o.max_range;
    const auto& sum = hits[k] ? hsum[k] : fsum[k];
    const double cnt = static_cast<double>(hits[k] ? hits[k] : frees[k]);
    for (int c = 0; c < d; ++c) s.centre[c] = sum[c] / cnt;
    s.hits.reserve(hits[k] * d);
    s.free.reserve(frees[k] * d);
    slot[k] = static_cast<int>(out.size());
    out.push_back(std::move(s));
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (which[i] < 0 || slot[which[i]] < 0) continue;
    Sector& s = out[slot[which[i]]];
    auto& dst = samples.label[i] ? s.hits : s.free;
    const double* p = &samples.position[i * d];
    for (int c = 0; c < d; ++c) dst.push_back((p[c] - s.centre[c]) * s.scale);
  }
  return out;
}

void build_dictionary(const std::vector<Scan>& scans, const KernelMap& map,
                      const DictionaryOptions& options, Dictionary& dict) {
  map.validate("build_dictionary: map");
  const int d = map.dim;
  if (!dict.empty() && (dict.dim != d || dict.scale != options.sectors.scale))
    throw ArgumentError("build_dictionary: the dictionary holds atoms of another dim or scale");
  if (dict.empty()) {
    dict.dim = d;
    dict.scale = options.sectors.scale;
    dict.sectors = options.sectors.sectors;
    dict.max_range = 0;
  }
  std::unique_ptr<detail::KernelIndex> index;  // built once, for kernels at samples
  for (std::size_t t = 0; t < scans.size(); ++t) {
    const Scan& scan = scans[t];
    if (scan.dim != d)
      throw ArgumentError("build_dictionary: scan " + std::to_string(t) + " is " +
                          std::to_string(scan.dim) + "D, the map " + std::to_string(d) + "D");
    SectorOptions so = options.sectors;
    if (so.max_range <= 0) so.max_range = scan.max_range;
    check_options(so, so.max_range, "build_dictionary");
    if (dict.max_range > 0 && std::abs(dict.max_range - so.max_range) > 1e-9 * so.max_range)
      throw ArgumentError("build_dictionary: scan " + std::to_string(t) + " has max_range " +
                          std::to_string(so.max_range) + " m, the dictionary " +
                          std::to_string(dict.max_range) + " m");
    dict.max_range = so.max_range;

    LabelledSplit split;
    label_scan(scan, static_cast<std::int64_t>(t), options.labels, split);
    if (split.train.empty()) continue;
    const auto sensor = scan.origin();
    const double heading = scan_heading(scan);
    std::vector<Sector> sectors = cut_sectors(split.train, sensor, heading, so);
    if (sectors.empty()) continue;

    std::vector<int> slot(so.sectors, -1);
    std::vector<Atom> atoms(sectors.size());
    for (std::size_t i = 0; i < sectors.size(); ++i) {
      slot[sectors[i].index] = static_cast<int>(i);
      atoms[i].kernels.dim = d;
      atoms[i].scan_index = static_cast<std::int64_t>(t);
      atoms[i].source = options.source;
    }
    const double r2max = so.max_range * so.max_range;
    std::vector<std::vector<double>> samples(sectors.size());
    std::vector<std::unique_ptr<detail::PointProximity>> near(sectors.size());
    if (options.max_sample_distance > 0)
      for (std::size_t i = 0; i < sectors.size(); ++i) {
        samples[i] = sectors[i].hits;
        samples[i].insert(samples[i].end(), sectors[i].free.begin(), sectors[i].free.end());
        near[i] = std::make_unique<detail::PointProximity>(
            samples[i], d, options.max_sample_distance * sectors[i].scale);
      }
    if (options.kernels_at_samples > 0) {
      if (!index) index = std::make_unique<detail::KernelIndex>(map, kDefaultCutoffTau);
      for (std::size_t i = 0; i < sectors.size(); ++i)
        anchored_kernels(map, *index, sectors[i], options, atoms[i].kernels);
    }
    double q[3];
    for (std::size_t m = 0; m < map.size() && options.kernels_at_samples <= 0; ++m) {
      const double* h = &map.position[m * d];
      const int k = sector_of(h, sensor, heading, r2max, so.sectors);
      if (k < 0 || slot[k] < 0 || !(map.w_var[m] <= options.max_weight_variance)) continue;
      const Sector& s = sectors[slot[k]];
      for (int c = 0; c < d; ++c) q[c] = (h[c] - s.centre[c]) * s.scale;
      if (near[slot[k]] && !near[slot[k]]->near(q)) continue;
      atoms[slot[k]].kernels.push_back(q, map.gamma[m], map.w_mean[m], map.w_var[m]);
    }
    for (std::size_t i = 0; i < sectors.size(); ++i) {
      if (atoms[i].kernels.size() < options.min_kernels) continue;
      atoms[i].sector = std::move(sectors[i]);
      dict.atoms.push_back(std::move(atoms[i]));
    }
  }
}

void merge_dictionary(const Dictionary& from, Dictionary& into) {
  if (from.empty()) return;
  if (into.empty()) {
    const int sectors = std::max(into.sectors, from.sectors);
    into = from;
    into.sectors = sectors;
    return;
  }
  if (from.dim != into.dim || from.scale != into.scale || from.max_range != into.max_range)
    throw ArgumentError("merge_dictionary: atoms of " + std::to_string(from.dim) + "D, scale " +
                        std::to_string(from.scale) + ", radius " + std::to_string(from.max_range) +
                        " m into a dictionary of " + std::to_string(into.dim) + "D, scale " +
                        std::to_string(into.scale) + ", radius " + std::to_string(into.max_range) +
                        " m");
  into.sectors = std::max(into.sectors, from.sectors);
  into.atoms.insert(into.atoms.end(), from.atoms.begin(), from.atoms.end());
}

std::size_t dictionary_memory_bytes(const Dictionary& dict) {
  std::size_t b = sizeof(Dictionary);
  for (const Atom& a : dict.atoms)
    b += sizeof(Atom) + a.source.capacity() +
         sizeof(double) * (a.sector.hits.capacity() + a.sector.free.capacity() +
                           a.kernels.position.capacity() + a.kernels.gamma.capacity() +
                           a.kernels.w_mean.capacity() + a.kernels.w_var.capacity());
  return b;
}

}  // namespace potmap
