// Held-out scores by range, height and kind of sample (score_breakdown.hpp).
#include "potmap/experiments/score_breakdown.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "potmap/error.hpp"

namespace potmap::experiment {

namespace {

// What label_scan gives beam b of `scan` cut at rmax: whether it ends in a hit, and its free
// samples (0 when the beam gives no sample at all).
void beam_samples(const Scan& scan, std::size_t b, double rmax, const LabelOptions& o, bool& hit,
                  long& nfree) {
  const int d = scan.dim;
  const auto org = scan.origin();
  const std::size_t nh = scan.num_hits();
  double len = rmax;
  hit = false;
  nfree = 0;
  if (b < nh) {
    double r2 = 0;
    for (int k = 0; k < d; ++k) {
      const double v = scan.hits[b * d + k];
      if (!std::isfinite(v)) return;
      r2 += (v - org[k]) * (v - org[k]);
    }
    const double r = std::sqrt(r2);
    hit = r < rmax;
    len = hit ? r : rmax;
  } else {
    double n2 = 0;
    for (int k = 0; k < d; ++k) n2 += std::pow(scan.no_return[(b - nh) * d + k], 2);
    if (!std::isfinite(n2) || n2 == 0 || !std::isfinite(rmax)) return;
  }
  const double want = std::min(len * o.free_per_metre, double(o.max_free_per_beam));
  nfree = std::max(1L, std::lround(want));
}

}  // namespace

SamplePlaces place_test_samples(const std::vector<Scan>& scans, const LabelOptions& labels,
                                std::int64_t first_index, const LabelledPoints& test) {
  SamplePlaces out;
  const std::size_t n = test.size();
  out.range.resize(n);
  out.height.resize(n);
  out.past_cut.resize(n);
  out.to_hit.assign(n, NAN);
  const int d = test.dim;
  std::size_t at = 0;
  auto fail = [](const std::string& why) {
    throw InputError("place_test_samples: the test set is not the scans' held-out samples (" + why +
                     ")");
  };
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const Scan& sc = scans[i];
    const std::int64_t t = first_index + std::int64_t(i);
    const std::vector<std::uint8_t> held = heldout_beams(sc, t, labels);
    const auto org = sc.origin();
    const double rmax = sc.max_range > 0 ? sc.max_range : HUGE_VAL;
    for (std::size_t b = 0; b < held.size(); ++b) {
      if (!held[b]) continue;
      bool hit = false;
      long nfree = 0;
      beam_samples(sc, b, rmax, labels, hit, nfree);
      const std::size_t count = std::size_t(nfree) + (hit ? 1 : 0);
      if (nfree == 0) continue;
      if (at + count > n) fail("too few samples");
      for (std::size_t j = 0; j < count; ++j, ++at) {
        const bool is_hit = hit && j == 0;
        if (test.label[at] != (is_hit ? 1 : 0)) fail("labels differ");
        if (!test.scan.empty() && test.scan[at] != t) fail("scan indices differ");
        const double* p = &test.position[at * d];
        out.range[at] = std::hypot(p[0] - org[0], p[1] - org[1]);
        out.height[at] = d == 3 ? p[2] - org[2] : 0.0;
        out.past_cut[at] = !hit;
        if (hit && j > 0) {
          const double* h = &test.position[(at - j) * d];  // the beam's hit, first
          double r2 = 0;
          for (int k = 0; k < d; ++k) r2 += (p[k] - h[k]) * (p[k] - h[k]);
          out.to_hit[at] = std::sqrt(r2);
        }
      }
    }
  }
  if (at != n) fail("too many samples");
  return out;
}

SampleKind sample_kind(bool hit, double height, bool past_cut, const BreakdownOptions& o) {
  if (hit) return height < o.ground_below ? SampleKind::ground_hit : SampleKind::other_hit;
  return past_cut ? SampleKind::free_past_cut : SampleKind::free_of_hit;
}

const char* kind_name(SampleKind k) {
  switch (k) {
    case SampleKind::ground_hit:
      return "hit ground";
    case SampleKind::other_hit:
      return "hit other";
    case SampleKind::free_of_hit:
      return "free (hit beam)";
    case SampleKind::free_past_cut:
      return "free (past cut)";
  }
  return "?";
}

std::size_t bin_index(double v, const std::vector<double>& edges, bool open_below) {
  if (edges.size() < (open_below ? 1u : 2u)) throw ArgumentError("bin_index: too few bin edges");
  for (std::size_t i = 1; i < edges.size(); ++i)
    if (!(edges[i] > edges[i - 1])) throw ArgumentError("bin_index: bin edges must increase");
  // Bins [edges[i], edges[i+1]) counted from the first edge.
  const std::size_t above =
      std::size_t(std::upper_bound(edges.begin(), edges.end(), v) - edges.begin());
  if (open_below) return above;
  return std::min(above == 0 ? 0 : above - 1, edges.size() - 2);
}

std::vector<std::string> bin_names(const std::vector<double>& edges, bool open_below) {
  std::vector<std::string> names;
  char buf[64];
  if (open_below) {
    std::snprintf(buf, sizeof buf, "< %g m", edges.front());
    names.push_back(buf);
  }
  for (std::size_t i = 0; i + 1 < edges.size(); ++i) {
    std::snprintf(buf, sizeof buf, open_below ? "%g..%g m" : "%g-%g m", edges[i], edges[i + 1]);
    names.push_back(buf);
  }
  if (open_below) {
    std::snprintf(buf, sizeof buf, ">= %g m", edges.back());
    names.push_back(buf);
  }
  return names;
}

std::vector<BinScores> score_breakdown(const std::vector<double>& prob, const LabelledPoints& test,
                                       const SamplePlaces& places, const BreakdownOptions& o) {
  const std::size_t n = test.size();
  if (prob.size() != n || places.range.size() != n || places.height.size() != n ||
      places.past_cut.size() != n)
    throw ArgumentError("score_breakdown: sizes differ");
  const std::vector<std::string> ranges = bin_names(o.range_edges, false);
  const std::vector<std::string> heights = bin_names(o.height_edges, true);
  // Every (axis, bin) in the order the table lists them, then each sample into its bins.
  std::vector<std::pair<std::string, std::string>> order;
  for (const std::string& r : ranges) order.emplace_back("range", r);
  order.emplace_back("range", "past cut");
  for (const std::string& h : heights) order.emplace_back("height", h);
  const SampleKind kinds[] = {SampleKind::ground_hit, SampleKind::other_hit,
                              SampleKind::free_of_hit, SampleKind::free_past_cut};
  for (SampleKind k : kinds) order.emplace_back("kind", kind_name(k));
  for (SampleKind k : kinds)
    for (const std::string& r : ranges)
      order.emplace_back("kind@range", std::string(kind_name(k)) + " " + r);
  const bool to_hit = places.to_hit.size() == n;
  const std::vector<std::string> near = bin_names(o.to_hit_edges, true);
  if (to_hit)
    for (const std::string& b : near) order.emplace_back("free to hit", b);
  std::map<std::pair<std::string, std::string>, std::vector<std::size_t>> members;
  for (std::size_t i = 0; i < n; ++i) {
    const bool past = places.past_cut[i] != 0;
    const std::string& r = ranges[bin_index(places.range[i], o.range_edges, false)];
    const SampleKind k = sample_kind(test.label[i] != 0, places.height[i], past, o);
    members[{"range", past ? "past cut" : r}].push_back(i);
    members[{"height", heights[bin_index(places.height[i], o.height_edges, true)]}].push_back(i);
    members[{"kind", kind_name(k)}].push_back(i);
    members[{"kind@range", std::string(kind_name(k)) + " " + r}].push_back(i);
    if (to_hit && k == SampleKind::free_of_hit && std::isfinite(places.to_hit[i]))
      members[{"free to hit", near[bin_index(places.to_hit[i], o.to_hit_edges, true)]}].push_back(
          i);
  }
  std::vector<BinScores> out;
  for (const auto& key : order) {
    const std::vector<std::size_t>& m = members[key];
    if (m.empty()) continue;
    std::vector<double> p(m.size());
    std::vector<std::uint8_t> y(m.size());
    for (std::size_t j = 0; j < m.size(); ++j) {
      p[j] = prob[m[j]];
      y[j] = test.label[m[j]];
    }
    out.push_back({key.first, key.second, score(p, y)});
  }
  return out;
}

}  // namespace potmap::experiment
