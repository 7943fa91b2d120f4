#pragma once
// Ordering atoms by a per-class distance to a target sector, shared by the descriptor
// pre-selection (atom_descriptor.cpp) and the atom index (atom_index.cpp). It mirrors the
// ranking score: each class's distance divided by its largest value over the atoms, summed;
// atoms lacking a class the target has come after every atom that has it.
#include <cstddef>
#include <vector>

namespace potmap::detail {

/// `dh`, `df`: per atom, the hits and free-sample distances (-1 where the atom lacks a class
/// the target has, 0 where the target lacks it). The k best atoms, best first (ties by index);
/// k = 0 or k >= atoms: every atom.
std::vector<std::size_t> order_by_class_distance(const std::vector<double>& dh,
                                                 const std::vector<double>& df, std::size_t k);

}  // namespace potmap::detail
