#pragma once
// What the transport and the placement at samples compute from an atom alone, kept per atom
// once made: the evenly thinned samples of its transport problems (as indices; the bisection
// over cell sizes was 0.3 ms a scan) and the class of each of its kernels (nearest sample a
// hit or a free sample; two nearest-point queries per kernel, 0.8 ms a scan at 200 atoms), and
// the atom's map at those thinned samples.
// Made on first use, under a per-atom once_flag, so a prepare thread and the transfer may ask
// at once. Held by AtomIndex (AtomIndex::transport_cache), built with the dictionary it serves.
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include <Eigen/Core>

#include "potmap/pot/atoms.hpp"

namespace potmap {

namespace detail {

/// Each kernel's class (0: its nearest atom sample is a hit, 1: a free sample) and, per class,
/// the sum and count of the kernels' widths.
struct KernelClasses {
  std::vector<std::uint8_t> cls;
  std::array<double, 2> gamma_sum{0, 0}, count{0, 0};
};
KernelClasses kernel_classes(const Atom& atom);

/// The atom's map at the points X (the problems' frame: atom units times `scale`) from its
/// kernels of class `cls` alone: logit means L and variances V (each class alone reproduces
/// the source map at its own samples).
struct SampleMap {
  Eigen::VectorXd mean, variance;
};
SampleMap atom_map_at(const Atom& atom, const KernelClasses& classes, int cls,
                      const Eigen::MatrixXd& X, double scale);

}  // namespace detail

struct AtomTransportCache {
  explicit AtomTransportCache(std::size_t atoms);

  /// The classes of atom `a`'s kernels (computed on first call).
  const detail::KernelClasses& classes(const Atom& atom, std::size_t a);
  /// Atom `a`'s hits (class 0) or free samples (1) thinned evenly to at most `cap`, as
  /// detail::subsample_even gives them. Cached for the cap of the first call; another cap is
  /// thinned on every call.
  Eigen::MatrixXd thinned(const Atom& atom, std::size_t a, int cls, std::size_t cap);
  /// detail::atom_map_at over thinned(atom, a, cls, cap), computed on first call (the
  /// placement's exps: 40,000 a 360-beam scan). Null when `cap` or `scale` differ from those
  /// it was made for: the caller computes it then.
  const detail::SampleMap* sample_map(const Atom& atom, std::size_t a, int cls, std::size_t cap,
                                      double scale);

 private:
  struct Thinned {
    std::once_flag once;
    std::size_t cap = 0;
    std::vector<std::uint32_t> keep;
    std::once_flag map_once;
    std::size_t map_cap = 0;
    double map_scale = 0;
    detail::SampleMap map;
  };
  std::vector<std::once_flag> class_once_;
  std::vector<detail::KernelClasses> classes_;
  std::vector<std::array<Thinned, 2>> thinned_;
};

}  // namespace potmap
