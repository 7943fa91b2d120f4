#pragma once
// Pieces shared by the ABHM reference and device paths.

#include <vector>

#include "potmap/learn/abhm.hpp"

namespace potmap::detail {

/// One reparameterised draw of every variable.
struct AbhmDraw {
  std::vector<double> w, h, g;
  double b = 0.0;
};
AbhmDraw abhm_draw(const AbhmParams& p, const AbhmNoise& noise);

/// Gradient of the loss in flat() order from the likelihood's derivatives in the drawn w, h,
/// gamma and bias (dw, dh, dg, db), through the reparameterisation, plus the KL gradients.
void abhm_chain(const AbhmParams& p, const AbhmPrior& prior, const AbhmNoise& noise,
                const std::vector<double>& g, const std::vector<double>& dw,
                const std::vector<double>& dh, const std::vector<double>& dg, double db,
                std::vector<double>& grad);

}  // namespace potmap::detail
