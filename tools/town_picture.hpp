#pragma once
// A built-in town as a person sees it: buildings and obstacles dark on white, the route of the
// scans red; on its own (captioned: title, legend, scale bar) or as the true town's panel beside
// an estimate. `potmap demo` and `potmap data simulate` draw it.
#include <cstddef>
#include <string>
#include <vector>

#include "potmap/data/simulator.hpp"
#include "potmap/experiments/figure_panels.hpp"

namespace potmap::cli {

/// The town over the window [lo, hi] (metres) at the scale probability_picture uses for it
/// (max(extent) / max_pixels metres a pixel), so that it stands beside the estimate pixel for
/// pixel. `route`: x, y of each scan.
experiment::Picture town_picture(const Town& town, const std::vector<double>& route,
                                 const double lo[3], const double hi[3], std::size_t max_pixels);

/// What town_picture's colours mean, for a legend.
std::vector<experiment::Swatch> town_swatches();

/// The whole town at 0.5 m a pixel to `path` (PNG), titled "THE TRUE TOWN <name> AND THE ROUTE
/// OF ITS SCANS", its colours and a scale bar below. Throws potmap::Error when it cannot be
/// written.
void write_true_town(const Town& town, const std::string& name, const std::vector<double>& route,
                     const std::string& path);

}  // namespace potmap::cli
