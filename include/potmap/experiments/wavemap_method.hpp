#pragma once
// wavemap as a method of the experiments (experiment.hpp): the same training beams as the
// OctoMap baseline, keyframe by keyframe, scored on the same held-out samples. Defined only in
// builds configured with -DPOTMAP_WAVEMAP_DIR (POTMAP_WITH_WAVEMAP); see wavemap_grid.hpp.

#include <string>

#include "potmap/experiments/experiment.hpp"
#include "potmap/experiments/wavemap_grid.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap::experiment {

struct WavemapSetup {
  /// Cell, ranges, measurement model (max_range 0: the task's cut). The beam's angular sigma
  /// is 0.3 degrees here, not the 0.05 of wavemap's OS1 configuration: the drives' keyframes
  /// are thinned clouds (about a point per square degree, docs/drives-3d.md), and with a raw
  /// scan's beam width most cells between their points got no update (riverside-a at 20 m:
  /// AUC 0.73 / NLL 0.63 against 0.89 / 0.33).
  WavemapOptions options = [] {
    WavemapOptions o;
    o.angle_sigma_deg = 0.3;
    return o;
  }();
  /// Pixel pitch of the range image, degrees (azimuth, elevation); the field of view is the
  /// task's training beams' (wavemap_projection). Default 1.4 x 2 degrees, the keyframes'
  /// density (wavemap's OS1 configuration: 1024 columns over 360 degrees, 64 rings).
  double azimuth_pitch_deg = 1.4;
  double elevation_pitch_deg = 2.0;
};

/// wavemap with `setup` (named "wavemap C m" for its cell C, group "wavemap"): every training
/// beam of every scan inserted in order, the map pruned at the end. fit_seconds covers the
/// inserts and the pruning; info holds cell_m, memory_mb (the map's own count), cells and the
/// range image's pixels.
Method wavemap_method(const WavemapSetup& setup);

}  // namespace potmap::experiment
POTMAP_CXX_API_END
