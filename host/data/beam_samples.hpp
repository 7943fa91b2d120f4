#pragma once
// The pieces of label_scan() that the keyframe gathering (keyframe_samples.cpp and its device
// path) shares with it, so that both draw the same samples from the same generator.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "potmap/data/labelling.hpp"
#include "sim_rng.hpp"

namespace potmap::data {

/// SplitMix64's increment: draw k after state s reads state s + (k + 1) * kGolden, so a beam's
/// draws start anywhere in the scan's stream without the draws before them.
constexpr std::uint64_t kGolden = 0x9e3779b97f4a7c15ULL;

/// The generator of one scan: the split is its first use, the free samples follow.
SimRng split_rng(std::int64_t scan_index, const LabelOptions& o);

/// Beam-level split: exactly round(fraction * beams) beams, by a partial Fisher-Yates shuffle.
std::vector<std::uint8_t> draw_split(std::size_t beams, const LabelOptions& o, SimRng& rng);

/// One beam's segment of free space: from the sensor along `dir` (unit; zero for a hit at the
/// sensor) for `len` metres, ending in the hit `end` when `hit`.
struct BeamSegment {
  double dir[3] = {0, 0, 0};
  double end[3] = {0, 0, 0};
  double len = 0;
  bool hit = false;
};

/// Beam b of the scan (hits first, then no-returns) from the sensor at `org`, cut at `rmax`
/// metres (HUGE_VAL: none). False when the beam gives no sample: a non-finite end point, a
/// no-return of no direction or with no range to sample up to.
bool beam_segment(const Scan& scan, std::size_t b, const double* org, double rmax,
                  BeamSegment& out);

/// Throws ArgumentError naming `who` for options label_scan() refuses.
void check_label_options(const LabelOptions& o, const char* who);

/// Free samples a beam of `len` metres gets: free_per_metre * len, rounded, at least one and at
/// most max_free_per_beam.
long free_samples(double len, const LabelOptions& o);

}  // namespace potmap::data
