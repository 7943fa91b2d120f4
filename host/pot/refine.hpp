#pragma once
// RePOT's weight refinement with the kernels' overlap accounted for (host/pot/refine.cpp).

#include "potmap/data/labelled_points.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/map/kernel_map.hpp"

namespace potmap::detail {

/// Jaakkola-Jordan EM like bhm_update_reference(), except that the E-step's mean solves the
/// whole linear system of the bound,
///   (diag(1/wvar0) + 2 Phi^T Lambda Phi) wbar = wbar0 / wvar0 + Phi^T (y - 1/2),
/// by preconditioned conjugate gradients, instead of its diagonal alone. The variances are the
/// mean-field ones, 1 / diagonal of that matrix (as in BHM). The mean is then the factorised
/// (mean-field) variational optimum; the diagonal update double-counts the samples that
/// several overlapping kernels share, which transported kernels do a lot. `map` holds the prior
/// on entry and the posterior on return; positions and widths are not touched; no bias weight.
void refine_joint(KernelMap& map, const LabelledPoints& samples, const BhmOptions& options);

}  // namespace potmap::detail
