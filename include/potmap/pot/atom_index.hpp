#pragma once
// An index over a dictionary's atoms for the indexed ranking (PotOptions::ranking):
// candidates for a target sector come from a nearest-neighbour query over rotation-invariant
// signatures, and each candidate's rotation is estimated by circular cross-correlation of
// angular histograms instead of trying every rotation with Sinkhorn.
//
// A sector's signature, per sample class (hits, free samples), in the sector frame (origin at
// the hit centroid, scaled units):
// - a polar histogram: `rings` radial rings by `bins` angular bins over the full circle, each
//   sample weighted by its radius (a rotation moves a point by its radius times the angle, so
//   far points say most about the rotation), the class summing to 1, smoothed along the angle;
// - rotation-invariant features: the radius quantiles of AtomDescriptor (the 1D W2 lower bound
//   on the OT cost under any rotation), then per ring the magnitudes of the first `harmonics`
//   angular Fourier coefficients of the histogram, times the ring's mean radius (so that, like
//   the quantile term, they are in squared scaled length once squared). A rotation shifts the
//   histogram along the angle, which changes the phase of each coefficient, not its magnitude.
//
// Query cost: the feature distance of every atom (brute force over a compact float matrix,
// about 64 floats an atom), then the cross-correlation at every angular shift for the k nearest.

#include <Eigen/Core>

#include <complex>
#include <cstddef>
#include <memory>
#include <vector>

#include "potmap/export.h"
#include "potmap/pot/atom_descriptor.hpp"
#include "potmap/pot/atoms.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// Per-atom results of the transport and the placement that depend on the atom alone, made on
/// first use (opaque; see AtomIndex::transport_cache).
struct AtomTransportCache;

/// Shape of the signatures. Defaults: 4 rings, 64 bins (5.6 degrees; the estimate is refined
/// between bins), 4 harmonics.
struct AtomIndexOptions {
  int rings = 4;      ///< radial rings (>= 1) of equal width up to the sector radius, the last open
  int bins = 64;      ///< angular bins of the full circle (>= 8)
  int harmonics = 4;  ///< Fourier magnitudes per ring in the features (0 .. bins / 2)
  /// Each atom's hits and free samples thinned evenly to at most this many, kept for the
  /// indexed ranking's coarse stage (defaults: PotOptions::coarse_hits and coarse_free; a
  /// ranking with other caps thins on every call instead). Thinning costs more than the rest
  /// of a scan's preparation, so it is done once here.
  std::size_t coarse_hits = 48;
  std::size_t coarse_free = 24;
};

/// The signature of one sector (see the top of this file).
struct SectorSignature {
  int dim = 2;
  std::size_t hits = 0, free = 0;                  ///< sample counts (0: that class is absent)
  std::vector<float> hit_features, free_features;  ///< rotation-invariant features per class
  std::vector<float> hit_polar, free_polar;        ///< rings x bins, row-major, per class
};

/// A rotation estimate: the angle that rotates the atom onto the target (radians,
/// counter-clockwise, in [0, 2 pi)) and its correlation (larger is better).
struct RotationEstimate {
  double angle = 0;
  double correlation = 0;
};

/// Signatures of every atom of a dictionary, built once, queried per target sector.
class AtomIndex {
 public:
  AtomIndex() = default;
  /// O(samples of the dictionary). Throws ArgumentError for bad options.
  explicit AtomIndex(const Dictionary& dict, const AtomIndexOptions& options = {});

  /// The signature of a target sector, with the index's options and radius. Throws
  /// ArgumentError when the sector's dimension differs from the dictionary's.
  SectorSignature signature(const Sector& sector) const;

  /// The k atoms nearest to the target by the feature distance, nearest first (ties by index).
  /// The distance mirrors the ranking score: per class, the squared feature distance divided by
  /// its largest value over the atoms, summed over the classes the target has; atoms that lack
  /// a class the target has come after every atom that has it. k = 0 or k >= size(): every atom.
  std::vector<std::size_t> nearest(const SectorSignature& target, std::size_t k) const;

  /// The atoms farthest from the target by the feature distance of each class the target has
  /// (one for the hits, one for the free samples; one atom when the same): the candidates that
  /// set the exhaustive ranking's normalisers, its largest costs. Empty when no atom has a
  /// class the target has.
  std::vector<std::size_t> farthest(const SectorSignature& target) const;

  /// Up to `count` rotation estimates of atom `atom` onto the target, best first: the highest
  /// peaks of the circular cross-correlation of the polar histograms (classes both sides have,
  /// summed), at least 45 degrees apart, each refined between bins by a parabola.
  std::vector<RotationEstimate> rotations(const SectorSignature& target, std::size_t atom,
                                          int count) const;

  /// Atom `atom`'s samples thinned to options().coarse_hits / coarse_free (rows are points).
  const Eigen::MatrixXd& coarse_hits(std::size_t atom) const { return coarse_hits_.at(atom); }
  const Eigen::MatrixXd& coarse_free(std::size_t atom) const { return coarse_free_.at(atom); }

  /// For the transfer of the dictionary this index was built on: what its transport and
  /// placement compute from an atom alone, kept once made (thread-safe). Null for an index made
  /// by the default constructor.
  AtomTransportCache* transport_cache() const { return transport_.get(); }

  std::size_t size() const { return hits_.size(); }
  const AtomIndexOptions& options() const { return options_; }
  /// Bytes held per atom (features, histograms and coarse samples; their mean).
  std::size_t bytes_per_atom() const;

 private:
  /// Per atom, the squared feature distance of each class to the target's (-1 where the atom
  /// lacks a class the target has; 0 where the target lacks it).
  void distances(const SectorSignature& t, std::vector<double>& dh, std::vector<double>& df) const;
  AtomIndexOptions options_;
  int dim_ = 2;
  double radius_ = 0;                     ///< sector radius in scaled units (max_range * scale)
  std::size_t features_ = 0;              ///< features per class
  std::vector<std::size_t> hits_, free_;  ///< sample counts per atom
  std::vector<float> hit_features_, free_features_;  ///< atoms x features_
  std::vector<float> hit_polar_, free_polar_;        ///< atoms x rings x bins
  std::vector<std::complex<double>> phase_;          ///< harmonics x bins phase factors
  std::vector<Eigen::MatrixXd> coarse_hits_, coarse_free_;
  std::shared_ptr<AtomTransportCache> transport_;
};

}  // namespace potmap
POTMAP_CXX_API_END
