#pragma once
// Comparison figures of the experiments: the probability pictures of several maps of one case,
// side by side at one scale, so that a map's shape can be judged against its neighbours'.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>
#include "potmap/export.h"

#include "potmap/experiments/experiment.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap::experiment {

/// An 8-bit RGB picture, rows top first.
struct Picture {
  std::size_t width = 0, height = 0;
  std::vector<std::uint8_t> rgb;  ///< width * height * 3 bytes
};

/// The probability picture write_figures writes as PREFIX_prob.png, in memory: the map's
/// query() at the pixel centres over [lo, hi] (x, y; metres; `dim` 3 at the middle height),
/// pixels of max(extent) / max_pixels metres (default 400, as write_figures), coloured viridis.
/// Maps of one window thus give pictures of one size and scale. Throws ArgumentError for an
/// empty window, max_pixels 0 or dim not 2 or 3.
Picture probability_picture(const FittedMap& map, int dim, const double lo[3], const double hi[3],
                            std::size_t max_pixels = 400);

/// Writes `panels` left to right into the PNG `path`, `gap` white columns between neighbours
/// (default 4: enough to see the edge of a panel whose border is dark), tops aligned, a panel
/// shorter than the tallest padded with white below. Null panels are skipped. Throws
/// ArgumentError when no panel has pixels, potmap::Error when the file cannot be written.
void write_side_by_side(const std::vector<const Picture*>& panels, const std::string& path,
                        std::size_t gap = 4);

}  // namespace potmap::experiment
POTMAP_CXX_API_END
