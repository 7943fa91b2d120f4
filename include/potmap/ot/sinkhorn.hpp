#pragma once
// Batched entropic optimal transport (log-domain Sinkhorn, SPEC section 4) on an OpenCL device,
// and a double-precision CPU reference to check it against.
//
// Cost of a pair: C_ij = | s * (c + R (x_i - c)) - s * y_j |^2, optionally divided by its maximum
// over the problem, where x are source points, y target points, R the rotation by `angle` about
// the centre c (about the vertical axis in 3D: z is not rotated) and s the scale. Units: the
// points' own (metres for raw scans); the cost is in squared scaled units (or unitless when
// normalised); epsilon is in the cost's units.

#include <boost/compute/buffer.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <memory>
#include <vector>

#include "potmap/export.h"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// One entropic OT problem. Points are rows (n x dim, dim 2 or 3, same dim in both sets).
struct SinkhornProblem {
  Eigen::MatrixXd source;          ///< n x dim source points x_i; n >= 1
  Eigen::MatrixXd target;          ///< m x dim target points y_j; m >= 1
  Eigen::VectorXd source_weights;  ///< a (n entries, positive, summing to 1); empty: uniform 1/n
  Eigen::VectorXd target_weights;  ///< b (m entries, positive, summing to 1); empty: uniform 1/m
  double angle = 0;                ///< rotation of the source, radians, counter-clockwise
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  ///< rotation centre (z ignored), point units
  double scale = 1;             ///< factor applied to both point sets before the cost; > 0
  double epsilon = 0.005;       ///< entropic regularisation (1/lambda), cost units; > 0
  int max_iterations = 1000;    ///< Sinkhorn iterations at the target epsilon; >= 1
  double tolerance = 1e-7;      ///< stop when ||P 1 - a||_1 < tolerance; > 0
  bool normalise_cost = false;  ///< divide the cost by its maximum over the problem
  /// Extra points (k x dim, same units as `source`) to send through the out-of-sample map
  /// T(h) = T_k + (R-rotated h - R-rotated x_k), k the source sample nearest to h. May be empty.
  Eigen::MatrixXd extra_points;
};

/// How the batch is solved; the defaults suit PoCL on a CPU.
struct SinkhornOptions {
  /// Convergence is checked every this many iterations at the target epsilon. The marginal
  /// error comes with every row update at no extra cost, so checking is nearly free. Default 1.
  int check_every = 1;
  /// Over-relaxation factor w of the updates at the target epsilon, f <- (1-w) f + w f_sinkhorn
  /// (same fixed point, so the same result; far fewer iterations near the optimal w).
  /// 0 (default): adaptive per problem, starting at 1.3 and raised towards
  /// 2 / (1 + sqrt(1 - eta^2)) as the observed error decay reveals plain Sinkhorn's contraction
  /// eta^2; 1: plain Sinkhorn; otherwise a fixed factor in (1, 2).
  double overrelaxation = 0;
  /// Epsilon scaling: one iteration at each of epsilon_start, epsilon_start * epsilon_decay, ...
  /// down to the problem's epsilon, then iterations at that epsilon until converged or
  /// max_iterations. The result is always the one at the problem's epsilon.
  double epsilon_start = 0;    ///< first epsilon, cost units; <= epsilon (default 0): none
  double epsilon_decay = 0.7;  ///< factor per annealing step, in (0, 1)
  /// Fill SinkhornResult::f and g (default true). false: cost and statistics only, one read
  /// from the device a launch instead of five, as a ranking that compares costs needs.
  bool want_duals = true;
  bool want_coupling = false;     ///< fill SinkhornResult::coupling (n x m dense)
  bool want_barycentric = false;  ///< fill SinkhornResult::barycentric (and extra_mapped)
  bool use_double = false;        ///< solve in double precision (needs cl_khr_fp64)
  /// Scheme. true (default): stabilised kernel-matrix iterations, K = exp(-C/eps + absorbed
  /// duals) stored in single precision (2 n m reals per running work-group, a few per compute
  /// unit, not per problem), multiply-adds instead of exps, scalings absorbed into the
  /// log-domain duals when they pass e^25, sums and scalings in double where the device has
  /// cl_khr_fp64, so that its marginal error can fall below the default 1e-7 tolerance. Same
  /// fixed point as the log domain.
  /// false: log-domain iterations with the cost recomputed online (memory n + m per problem,
  /// an exp per entry per iteration, duals in single precision, so its marginal error stops
  /// far above the stabilised scheme's). The error floors of both are in docs/accuracy.md.
  bool stabilised = true;
  /// Stabilised scheme: its sums, scalings and log marginals in double where the device has
  /// cl_khr_fp64 (default true): in single precision the 1-norm marginal error stalls near 2e-7
  /// to 5e-7, above the default 1e-7 tolerance. false: single precision, for batches whose
  /// tolerances are 1e-6 or looser, where every product streams twice the lanes a vector
  /// (POT's coarse ranking and its transport take it; measured in docs/pot-scale.md).
  /// Ignored by the log-domain scheme, whose sums are in REAL.
  bool double_sums = true;
  /// Work-items per problem (a power of two); 0 (default): the context's tuning
  /// (SinkhornTuning::work_group, potmap/runtime/tuning.hpp).
  int work_group = 0;
};

/// Whether single-precision sums (SinkhornOptions::double_sums false) reach `tolerance` on the
/// 1-norm marginal error: from 1e-6 up, five times their floor.
inline bool single_sums_reach(double tolerance) {
  return tolerance >= 1e-6;
}

/// What one problem came to. Duals f, g are in cost units (f_i/eps + log a_i convention of
/// SPEC section 4 undone), defined up to a constant shared with opposite signs.
struct SinkhornResult {
  double cost = 0;               ///< <P, C> with the cost actually used (normalised if asked)
  int iterations = 0;            ///< iterations done, annealing steps included
  double marginal_error = 0;     ///< ||P 1 - a||_1 of the returned plan
  bool converged = false;        ///< marginal_error < tolerance; false when the limit stopped it
  Eigen::VectorXd f, g;          ///< dual potentials (n and m entries)
  Eigen::MatrixXd coupling;      ///< n x m plan, only with want_coupling
  Eigen::MatrixXd barycentric;   ///< n x dim: T_i = sum_j P_ij y_j / sum_j P_ij (target units)
  Eigen::MatrixXd extra_mapped;  ///< k x dim: out-of-sample images of extra_points
};

class SinkhornBatch;

/// A batch's solve in flight on the device (SinkhornBatch::start): the caller's thread is free
/// until wait(). The batch it came from must stay alive and unchanged until then. Destroyed
/// without wait(), it blocks until the device is done with its buffers.
class SinkhornRun {
 public:
  SinkhornRun();
  SinkhornRun(SinkhornRun&&) noexcept;
  SinkhornRun& operator=(SinkhornRun&&) noexcept;
  ~SinkhornRun();
  /// Blocks until every problem is solved and returns the results in problem order (as
  /// SinkhornBatch::run). Once only: ArgumentError on a second call or a default-made run.
  std::vector<SinkhornResult> wait();

 private:
  friend class SinkhornBatch;
  struct State;
  std::unique_ptr<State> state_;
};

/// A batch of independent problems solved in one device launch.
class SinkhornBatch {
 public:
  /// Adds a problem and returns its index. Checks it at once: ArgumentError for empty point
  /// sets, mixed dimensions or bad parameters, InputError for NaN/Inf points (index named).
  std::size_t add(SinkhornProblem problem);
  std::size_t size() const { return problems_.size(); }
  const SinkhornProblem& problem(std::size_t i) const { return problems_[i]; }
  /// Solves every problem on the context's device; results in problem order.
  std::vector<SinkhornResult> run(Context& ctx, const SinkhornOptions& options = {}) const;
  /// The same solve, started and not waited for: the host can prepare what does not depend on
  /// the results while the device works (on a GPU that time is free; on a CPU device it fills
  /// the cores the launch leaves idle). run(ctx, o) is start(ctx, o).wait(). A batch larger
  /// than one launch (SinkhornTuning::chunk_slots) starts its first launch here and the rest in
  /// wait(), one at a time.
  SinkhornRun start(Context& ctx, const SinkhornOptions& options = {}) const;

 private:
  std::vector<SinkhornProblem> problems_;
  int dim_ = 0;
};

/// Layout of a batch already on the device, for callers that keep their data there. All
/// buffers belong to the caller; sinkhorn_device() only enqueues work on ctx.queue().
struct SinkhornDeviceBatch {
  int dim = 2;
  std::size_t problems = 0;
  boost::compute::buffer source;  ///< float, all source points (AoS, dim per point)
  boost::compute::buffer target;  ///< float, all target points (AoS)
  /// Per problem (host side): offsets (in points) and sizes into `source` and `target`.
  std::vector<int> source_offset, source_count, target_offset, target_count;
  /// Per problem parameters, as in SinkhornProblem. Only the scalar members are read (points
  /// and weights are ignored: marginals are uniform on this path).
  std::vector<SinkhornProblem> params;
};

/// Device-side results of sinkhorn_device().
struct SinkhornDeviceResult {
  boost::compute::buffer stats;        ///< float, 4 per problem: cost, iterations, error, converged
  boost::compute::buffer barycentric;  ///< float, dim per source point, same offsets as source
  /// float, each problem's n x m plan column by column (column-major: P_ij at
  /// coupling_offset + j n + i), back to back (if asked)
  boost::compute::buffer coupling;
  std::vector<long> coupling_offset;  ///< first element of each problem's plan
  /// The launch's own working buffers (problem table, duals, scratch). The enqueued kernel
  /// still uses them: keep this result alive until ctx.queue() has finished (PoCL frees a
  /// released buffer under a queued kernel).
  std::vector<boost::compute::buffer> working;
};

/// Enqueues the solve of a device batch; returns without waiting (results valid once
/// ctx.queue() has finished; keep the result until then). Uniform marginals; for given
/// marginals use SinkhornBatch.
SinkhornDeviceResult sinkhorn_device(Context& ctx, const SinkhornDeviceBatch& batch,
                                     const SinkhornOptions& options = {});

/// Double-precision CPU reference (log-domain, dense cost). Same conventions and stopping rule
/// (error checked every iteration), no annealing. Fills coupling and barycentric always.
SinkhornResult sinkhorn_reference(const SinkhornProblem& problem);

/// The out-of-sample map of SPEC step 4: each row h of `points` (k x dim, source units) goes to
/// T_k + R (h - x_k), x_k the source sample nearest to h, T = `barycentric` (n x dim, target
/// units), R the problem's rotation (about the vertical axis in 3D). Host code, brute force.
Eigen::MatrixXd out_of_sample_map(const SinkhornProblem& problem,
                                  const Eigen::MatrixXd& barycentric,
                                  const Eigen::MatrixXd& points);

/// The cost matrix C (n x m) of a problem as defined at the top of this file, in double.
Eigen::MatrixXd sinkhorn_cost(const SinkhornProblem& problem);

}  // namespace potmap
POTMAP_CXX_API_END
