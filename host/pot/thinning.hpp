#pragma once
// Thinning a sector's samples for Sinkhorn problems: seeded random subsamples (the ranking's,
// as the authors' code draws them) and evenly spread ones (the transport's and the indexed
// ranking's coarse stage).
#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace potmap::detail {

/// A seed mixed from three values (reproducible per seed, atom or scan, and sector).
std::uint64_t mix(std::uint64_t a, std::uint64_t b, std::uint64_t c);

/// At most `cap` of the points (dim per point), chosen by a seeded partial Fisher-Yates shuffle;
/// all of them, in order, when there are few enough.
Eigen::MatrixXd subsample(const std::vector<double>& pts, int dim, std::size_t cap,
                          std::uint64_t seed);

/// Indices of one point per occupied cell of edge `cell` (the first in input order), dim
/// coordinates per point.
std::vector<std::size_t> thin_to_cells(const std::vector<double>& pts, int dim, double cell);

/// At most `cap` points spread evenly over the cloud: one point (the first in input order) per
/// cell of the finest square (cubic) grid that has at most `cap` occupied cells. A random
/// subsample keeps the cloud's density, so two random subsamples of matching places differ
/// point by point and their plan is noisy and slow to converge; evenly spread ones look alike.
Eigen::MatrixXd subsample_even(const std::vector<double>& pts, int dim, std::size_t cap);
/// The indices (in input order) of the points subsample_even keeps.
std::vector<std::size_t> even_indices(const std::vector<double>& pts, int dim, std::size_t cap);

}  // namespace potmap::detail
