#pragma once
// Online Bayesian Hilbert map with the joint Jaakkola-Jordan posterior (SPEC section 3).
//
// Kernels sit on a regular grid with one width, close enough to overlap (a continuous map needs
// neighbouring kernels to share samples). With overlap, the diagonal posterior of bhm.hpp
// counts every sample once per kernel it reaches and becomes overconfident; this learner keeps
// the whole posterior precision instead,
//
//   P   = diag(1/w_var0) + 2 sum_n lambda(xi_n) phi_n phi_n^T      (sparse: only kernels that
//   eta = w_mean0/w_var0 + sum_n (y_n - 1/2) phi_n                   share a sample couple)
//   mean = P^-1 eta
//
// and adds each scan to P and eta (the posterior of one scan is the prior of the next, exactly,
// for the xi of that scan). Each scan runs a few EM iterations over its own xi_n; the means are
// solved by conjugate gradients warm-started from the previous scan, on the kernels the scan
// reaches plus a margin. P is stored per kernel as a stencil of its grid neighbours.
//
// A KernelMap carries one variance per kernel, so the exported w_var is chosen to reproduce the
// posterior's predictive variance phi(x)^T P^-1 phi(x) at each kernel centre (computed on a
// local block of P around the kernel); see JointBhm::map().

#include <cstddef>
#include <cstdint>
#include <vector>

#include "potmap/export.h"
#include "potmap/kernel_map.hpp"
#include "potmap/labelled_points.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct JointBhmOptions {
  /// Grid spacing of the kernels, metres (default 0.5: the hinge spacing of the BHM authors'
  /// demo on the Intel log; about the thickness of an indoor wall, so walls come out as walls).
  double spacing = 0.5;
  /// Kernel width, 1/m^2; 0 (default): -ln(neighbour_phi) / spacing^2.
  double gamma = 0;
  /// With gamma 0: the feature value of a kernel at one spacing from its centre (default 0.19,
  /// as gamma 6.71 at 0.5 m in the BHM authors' Intel demo). Larger: smoother, blurrier maps.
  double neighbour_phi = 0.19;
  /// Prior weight variance (default 10: as the BHM authors' demo; with overlapping kernels a
  /// large prior lets neighbours cancel one another in unobserved gaps).
  double prior_var = 10;
  /// A bias weight with the same prior (default true): it sets the level of unobserved space.
  bool bias = true;
  /// EM iterations on a scan (default 3); each but the last is followed by an M-step.
  int em_iterations = 3;
  /// Kernel cut-off exponent for the features: gamma d^2 > tau counts as 0 (default 18, as
  /// the evaluators).
  double tau = kDefaultCutoffTau;
  /// Conjugate-gradient stop: relative residual of a scan's solve (default 1e-5).
  double cg_tolerance = 1e-5;
  /// At most this many CG iterations per solve (default 300).
  int cg_max_iterations = 300;
  /// Extra rings of kernels, in spacings, solved around the ones a scan reaches (default 4: the
  /// change of the mean decays over a few kernel widths).
  int solve_margin = 4;
};

/// Counters of the last update() (for tests, benchmarks and progress).
struct JointBhmStats {
  std::size_t samples = 0;        ///< samples of the scan inside the grid
  std::size_t active = 0;         ///< kernels solved for
  std::size_t cg_iterations = 0;  ///< summed over the EM iterations
  double residual = 0;            ///< relative residual at the end of the last solve
};

/// The online learner. Not thread-safe; cheap to move.
class JointBhm {
 public:
  /// Kernels on a grid over [lo, hi] (metres; `dim` = 2 or 3 axes used), starting at lo and
  /// `options.spacing` apart. Throws ArgumentError on bad options or bounds, or more than
  /// 2^26 kernels.
  JointBhm(int dim, const double lo[3], const double hi[3], const JointBhmOptions& options = {});

  /// Adds one scan's labelled samples (any scan index; samples outside the grid's reach are
  /// ignored). Empty input does nothing. Throws ArgumentError on a dimension mismatch.
  void update(const LabelledPoints& samples);

  /// Adds the samples of every scan index in increasing order, one update() per scan.
  void update_by_scan(const LabelledPoints& samples);

  /// Seeds the prior of the kernels no sample has reached yet from another map over the same
  /// place (RePOT: the scan's transported kernels). Where `field`'s kernels weigh at least
  /// `min_support` (sum of their phi at the grid kernel), the grid kernel's prior becomes the
  /// weight and variance that reproduce field's logit mean and variance there, the variance
  /// clamped to [min_var, prior_var]. Kernels a sample already reached keep their posterior;
  /// the bias is untouched. Returns the number of kernels seeded. Throws ArgumentError on a
  /// dimension mismatch.
  std::size_t seed_unreached(const KernelMap& field, double min_var = 1.0,
                             double min_support = 0.3);

  /// The map: every grid kernel with its posterior mean, and the variance that reproduces the
  /// predictive variance at its centre (the prior variance where no sample reached it); the
  /// bias weight with its posterior. Polishes the means with a global solve first.
  KernelMap map();

  /// Posterior mean and variance of the logit at n points (n * dim coordinates), exactly:
  /// phi^T P^-1 eta and phi^T P^-1 phi, by a sparse Cholesky factorisation of the whole
  /// precision and one solve per point (no conjugate gradients): for tests and small maps.
  void predict_exact(const double* points, std::size_t n, double* mean, double* var);

  std::size_t size() const;  ///< kernels (without the bias)
  double gamma() const { return gamma_; }
  const JointBhmOptions& options() const { return o_; }
  const JointBhmStats& last_stats() const { return stats_; }

 private:
  struct Feature {
    std::uint32_t kernel;  // storage index
    std::int32_t cell[3];  // storage grid coordinates
    double phi;
  };
  void features(const double* x, std::vector<Feature>& out) const;
  void add_outer(const std::vector<Feature>& f, double c);
  // y = P x on the rows `rows` (storage indices); the bias row when with_bias.
  void multiply(const std::vector<double>& x, double xb, const std::vector<std::uint32_t>& rows,
                std::vector<double>& y, double& yb) const;
  double solve(const std::vector<std::uint32_t>& rows, double tol, int max_it, std::size_t* its);
  double predictive_var_at(std::uint32_t k, std::vector<double>& block_scratch) const;

  JointBhmOptions o_;
  int dim_ = 2;
  double gamma_ = 0, rcut_ = 0;
  double lo_[3] = {0, 0, 0};
  std::int64_t n_[3] = {1, 1, 1};        // interior kernels per axis
  std::int64_t pad_ = 0;                 // storage rings on each side (stencil half-width)
  std::int64_t sn_[3] = {1, 1, 1};       // storage cells per axis (interior + 2 pad)
  std::vector<std::int64_t> offset_;     // stencil slot -> storage index difference
  std::int64_t box_ = 0;                 // 2 * pad + 1
  std::int64_t slots_ = 0;               // box^dim
  std::vector<double> prec_;             // storage x stencil
  std::vector<double> eta_;              // storage
  std::vector<double> mean_;             // storage
  std::vector<double> bcoup_;            // storage: P(bias, k)
  std::vector<std::uint8_t> touched_;    // storage: a sample reached it
  std::vector<std::uint8_t> seeded_;     // storage: its prior came from seed_unreached()
  double grid_sum_ = 1, grid_sum2_ = 1;  // sum of phi, phi^2 of the grid at an interior kernel
  double pbb_ = 0, etab_ = 0, meanb_ = 0;
  JointBhmStats stats_;
};

}  // namespace potmap
POTMAP_CXX_API_END
