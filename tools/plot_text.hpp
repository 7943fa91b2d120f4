#pragma once
// Labels on the plots of `potmap bench` and the drive pictures: the experiments' pixel font
// (experiments/figure_panels.hpp).

#include "potmap/experiments/figure_panels.hpp"

namespace potmap::cli {

using experiment::draw_text;
using experiment::text_advance;

}  // namespace potmap::cli
