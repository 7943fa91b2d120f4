#pragma once
// What the experiments ask of a grid peer's fitted map (OctoMap, wavemap): its probability at
// the held-out samples (no variance: a grid has none, NaN) and which samples it observed.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>

#include "potmap/experiments/experiment.hpp"

namespace potmap::experiment::detail {

/// Sets f.query and f.known from `grid`'s probability(pts, n, prob) and observed(pts, n,
/// known); the map keeps the grid alive.
template <class Grid>
void set_grid_queries(FittedMap& f, std::shared_ptr<Grid> grid) {
  f.query = [grid](const double* pts, std::size_t n, double* prob, double* var) {
    grid->probability(pts, n, prob);
    if (var)
      for (std::size_t i = 0; i < n; ++i) var[i] = std::numeric_limits<double>::quiet_NaN();
  };
  f.known = [grid](const double* pts, std::size_t n, std::uint8_t* known) {
    grid->observed(pts, n, known);
  };
}

}  // namespace potmap::experiment::detail
