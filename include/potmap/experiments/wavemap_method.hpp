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
  WavemapOptions options;  ///< cell, ranges, measurement model (max_range 0: the task's cut)
  /// Pixel pitch of the range image, degrees (azimuth, elevation); the field of view is the
  /// task's training beams' (wavemap_projection). Defaults: an Ouster OS1-64's, 1024 columns
  /// over 360 degrees and 64 rings over 33.3 degrees (wavemap's OS1 configuration).
  double azimuth_pitch_deg = 360.0 / 1024;
  double elevation_pitch_deg = 33.3 / 64;
};

/// wavemap with `setup` (named "wavemap C m" for its cell C, group "wavemap"): every training
/// beam of every scan inserted in order, the map pruned at the end. fit_seconds covers the
/// inserts and the pruning; info holds cell_m, memory_mb (the map's own count), cells and the
/// range image's pixels.
Method wavemap_method(const WavemapSetup& setup);

}  // namespace potmap::experiment
POTMAP_CXX_API_END
