#pragma once
// Evaluating a kernel map: mean, variance and occupancy probability (SPEC section 2) at query
// points or on a regular grid, on an OpenCL device, with an exact CPU reference.
//
// Accuracy of the device evaluator, against evaluate_exact on the same map and points:
//   * kernels with gamma * d^2 > tau are skipped (tau = 18: each dropped term is below
//     1.6e-8 of its weight);
//   * positions are split into two floats (hi + lo), so coordinate differences keep float's
//     relative precision in any frame (UTM included);
//   * exp and products in float; sums in blocks of 16 kernels, the block sums added with
//     compensated (Neumaier) summation.
// The bounds the tests hold it to (tests/evaluate_test.cpp) are in docs/accuracy.md.

#include <boost/compute/buffer.hpp>
#include <boost/compute/event.hpp>
#include <boost/compute/utility/wait_list.hpp>

#include <cstddef>
#include <memory>
#include <vector>

#include "potmap/export.h"
#include "potmap/map/kernel_map.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct VoxelBlocks;  // map/voxel_blocks.hpp

/// Values of the map at a set of points (float: what the device computes).
struct MapValues {
  std::vector<float> mean;  ///< mu(x)
  std::vector<float> var;   ///< s2(x)
  std::vector<float> prob;  ///< p(x) in [0, 1]
};

/// Values of the map in double precision (the reference).
struct MapValuesExact {
  std::vector<double> mean;
  std::vector<double> var;
  std::vector<double> prob;
};

/// A regular grid of query points: cell centres origin[d] + (i + 0.5) * resolution for
/// i < count[d]. Flattened index: x fastest, then y, then z (i + nx * (j + ny * k)).
struct GridSpec {
  int dim = 2;                       ///< 2 or 3
  double origin[3] = {0, 0, 0};      ///< lower corner of cell (0, 0[, 0]), metres
  double resolution = 1.0;           ///< cell edge, metres, > 0
  std::size_t count[3] = {0, 0, 1};  ///< cells along x, y (and z in 3D; 1 in 2D)
  std::size_t cells() const { return count[0] * count[1] * (dim == 3 ? count[2] : 1); }
  /// Grid covering [lo, hi] on every axis (count = ceil((hi - lo) / resolution)).
  static GridSpec covering(int dim, const double lo[3], const double hi[3], double resolution);
};

/// Options of the device evaluator.
struct EvalOptions {
  /// Cut-off exponent, gamma * d^2 > tau is dropped; default 18. A map learned with a smaller
  /// cut-off (KernelMap::cutoff_tau) is evaluated at that.
  double tau = kDefaultCutoffTau;
  /// Query points per device launch (bounds device memory: about 40 bytes a point plus the
  /// kernel lists). Default 2^21.
  std::size_t points_per_launch = std::size_t(1) << 21;
  /// Grid cells per device launch (12 bytes a cell plus lists). Default 2^22.
  std::size_t cells_per_launch = std::size_t(1) << 22;
};

/// Probability from mean and variance: sigmoid(mean / sqrt(1 + pi * var / 8)).
double probit_probability(double mean, double var);

/// Exact dense sum in double over every kernel (no cut-off): the reference. `points` holds
/// n * map.dim coordinates, row-major. Multi-threaded over points with OpenMP where available.
MapValuesExact evaluate_exact(const KernelMap& map, const double* points, std::size_t n);
/// Exact reference on a grid.
MapValuesExact evaluate_exact(const KernelMap& map, const GridSpec& grid);

/// Evaluates one map on one device. The map is validated and uploaded once; evaluate() may then
/// be called any number of times. Not thread-safe: use one evaluator per thread (or lock).
/// Several evaluators on one Context may run on different threads at once (see context.hpp).
/// The evaluator keeps a pointer to its Context, which must outlive it.
class MapEvaluator {
 public:
  MapEvaluator(Context& ctx, const KernelMap& map, const EvalOptions& options = {});
  ~MapEvaluator();
  MapEvaluator(MapEvaluator&&) noexcept;
  MapEvaluator& operator=(MapEvaluator&&) noexcept;

  /// Values at n points (n * dim coordinates, row-major). Any output pointer may be null; the
  /// others receive n floats. n == 0 does nothing. Non-finite coordinates give NaN outputs.
  void evaluate(const double* points, std::size_t n, float* mean, float* var, float* prob);
  MapValues evaluate(const std::vector<double>& points);

  /// Values on a grid (GridSpec order). Outputs may be null; others receive grid.cells() floats.
  void evaluate_grid(const GridSpec& grid, float* mean, float* var, float* prob);
  MapValues evaluate_grid(const GridSpec& grid);

  /// Height-band maximum of a 3D map (map/height_band.hpp) on the (x, y) cells of `columns`
  /// (dim 3; count[2] and origin[2] are ignored): per cell, the largest probability over the
  /// heights `levels` (metres, map frame; from height_band_levels) and the variance and mean at
  /// that level. The levels are evaluated and reduced on the device; only the band comes back.
  /// Outputs may be null; the others receive count[0] * count[1] floats, x fastest. No levels or
  /// no cells does nothing. Throws ArgumentError for a 2D map or non-finite levels.
  void evaluate_band_max(const GridSpec& columns, const std::vector<double>& levels, float* mean,
                         float* var, float* prob);

  /// Values at every voxel of 3D blocks (map/voxel_blocks.hpp: 4096 values a block, block after
  /// block): the logit's variance, the probability and the support sum_m phi_m^2 (the sum of
  /// the kernels' squares, which io/known_cells.hpp's rule reads). Outputs may be null; the
  /// others receive blocks.size() * 4096 floats. Each block is evaluated with the kernels that
  /// reach it (kernels/map/blocks.cl, separable factors: a multiply-add per kernel and voxel);
  /// sums in float, p within 1e-5 of evaluate_blocks_exact. Throws ArgumentError for a 2D map or
  /// a voxel that is not positive.
  void evaluate_blocks(const VoxelBlocks& blocks, float* var, float* prob, float* support);

  /// Values at n points that already live on the device, for a host mapper that keeps its data
  /// there. `points`: n * dim floats (x, y[, z] per point), metres relative to `origin` (dim
  /// doubles, metres, in the map's frame; keep points within a few km of it for millimetre
  /// precision). Outputs: buffers of at least n floats, or null to skip. All buffers must belong
  /// to the evaluator's OpenCL context. The launch waits for `events` and is not waited for:
  /// the returned event completes when the outputs are written. n == 0 enqueues nothing and
  /// returns an empty event. Points are processed in any order (no sorting): a uniform grid of
  /// per-cell kernel lists is built on the first call and kept (about 4 bytes per kernel and
  /// cell it reaches).
  boost::compute::event evaluate_device(const boost::compute::buffer& points, std::size_t n,
                                        const double* origin, boost::compute::buffer* mean,
                                        boost::compute::buffer* var, boost::compute::buffer* prob,
                                        const boost::compute::wait_list& events = {});

  /// Kernel-query pairs visited by the last call (work done, for benchmarks).
  std::size_t last_pairs() const;
  int dim() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace potmap
POTMAP_CXX_API_END
