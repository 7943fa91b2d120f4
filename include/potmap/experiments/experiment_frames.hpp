#pragma once
// Single 3D frames (SPEC section 4, step 8; section 5): one LIDAR frame, sensor at the origin, no
// pose, 20 % of its beams held out; BHM on the frame's own training beams against POT and RePOT
// with atoms from other 3D frames (the simulator's 3D towns, or another real frame), every method
// scored on the same held-out beams. `potmap experiment frames` and tests/frames3d_test.cpp run it.
//
// The 3D defaults (frame_setup_3d) are chosen from the source data and the sensors' geometry,
// never from held-out beams; docs/results-3d.md has the measurements behind them.

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/export.h"
#include "potmap/map/metrics.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap::experiment {

/// Settings of one frame's evaluation.
struct FrameSetup {
  /// Every frame (target and source) cut at this horizontal range, metres (default 20: POT's
  /// sector radius and the simulated towns' range); limit_range().
  double max_range = 20;
  /// Labelling of the target frame (holdout_fraction 0.2; free_per_metre: see frame_setup_3d);
  /// the seed is the evaluation's.
  LabelOptions labels;
  /// Area margin around the hits, metres (make_task).
  double area_margin = 5;
  BhmSetup bhm;  ///< the BHM baseline on the frame
  PotSetup pot;  ///< POT and RePOT (pot.refine is set per method)
  /// Rotations tried per atom about the vertical axis, evenly spaced (default 8: 45 degrees).
  std::size_t rotations = 8;
};

/// The 3D defaults. Each is chosen from the sensor geometry and source data only:
///  - labels: 0.5 free samples per metre (a 3D frame has 20k to 35k beams; at 1 per metre its
///    free samples are 90 % of the data and the joint BHM's cost is in them);
///  - BHM: joint posterior, kernels 1 m apart, gamma -ln(0.19) (neighbours overlap as in 2D);
///    1 m is the vertical resolution of the rings at 10 m (2 degrees: 0.35 m on the 32-beam
///    nuScenes sensor, 1.4 degrees on the simulated one); 0.5 m costs 8 times the kernels,
///    each with its half precision stencil (126 doubles);
///  - POT: atoms with kernels at their own samples thinned to the BHM spacing, wall clearance
///    of one spacing, RePOT's persistent map the frame's BHM.
FrameSetup frame_setup_3d();

/// The simulated 3D sensor of the source towns: 32 rings from -30 to +10 degrees at 1.84 m
/// (the nuScenes roof LIDAR's geometry), 1 degree azimuth steps, 20 m range.
SimOptions sim_options_3d(std::size_t scans, std::uint64_t seed, double spacing = 4.0);

/// One method's score on the frame.
struct FrameResult {
  std::string source;  ///< label of the atoms' source; empty for BHM
  std::string method;  ///< "BHM", "POT", "RePOT"
  Scores scores;
  double fit_s = 0;    ///< wall time of the fit of this frame (POT: transfer; atoms are offline)
  double query_s = 0;  ///< wall time of scoring the held-out samples
  std::map<std::string, double> info;
  FittedMap map;
};

/// A frame's task, its held-out samples and the results.
struct FrameEvaluation {
  MapTask task;
  LabelledPoints test;
  std::vector<FrameResult> results;
};

/// A named source of atoms: one vector of 3D scans per place.
struct FrameSource {
  std::string label;
  std::vector<std::vector<Scan>> places;
};

/// Labels `frame` (cut at setup.max_range) with setup.labels and `seed`, fits the methods of
/// `methods` ("bhm", "pot", "repot") and scores each on the held-out beams. POT and RePOT run
/// once per source; their atoms are built once per (source label, seed) in `cache` (made when
/// null). Throws ArgumentError on an unknown method or a frame that is not 3D.
FrameEvaluation evaluate_frame(Context* ctx, const Scan& frame,
                               const std::vector<FrameSource>& sources, const FrameSetup& setup,
                               std::uint64_t seed,
                               const std::vector<std::string>& methods = {"bhm", "pot", "repot"},
                               std::shared_ptr<AtomCache> cache = nullptr);

/// Pictures of a frame at height `z` (metres, world frame): PREFIX_hits.png, the frame's hits
/// within +-`band` metres of z (training beams grey, held-out black, the sensor red; titled, with
/// its legend and a scale bar, picture_caption.hpp), and for every result
/// PREFIX_<source>_<method>_prob.png (write_figures of the horizontal slice at z). The window
/// is the task's x, y area. Returns the files written.
std::vector<std::string> write_frame_figures(const FrameEvaluation& e, const Scan& frame, double z,
                                             double band, const std::string& prefix,
                                             std::size_t max_pixels = 400);

}  // namespace potmap::experiment
POTMAP_CXX_API_END
