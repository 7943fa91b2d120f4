#pragma once
// The parts of merging (bhm_joint_merge.cpp) and of the map file's information form
// (bhm_joint_file.cpp) that read a JointBhm's private state.

#include <cstdint>
#include <string>

#include "potmap/learn/bhm_joint.hpp"

namespace potmap::detail {

struct JointBhmMerge {
  /// Refuses a map whose information form is not a sum of data over the prior.
  static void check_alone(const JointBhm& m, const std::string& name);
  /// Refuses two maps whose kernels or priors differ, naming both and the value.
  static void check_same_lattice(const JointBhm& a, const JointBhm& b, const std::string& na,
                                 const std::string& nb);
  /// c's information += b's data (c and b on the same lattice).
  static void add(JointBhm& c, const JointBhm& b);
  /// Solves c's means over every kernel with data or a seed.
  static void solve_means(JointBhm& c);
  /// The grid as the constructor took it: bounded maps' origin and kernels per axis.
  static int dim(const JointBhm& m) { return m.dim_; }
  /// The half-life of a learner read from a file (its options' other fields come first).
  static void set_half_life(JointBhm& m, double half_life) { m.o_.half_life = half_life; }
  static void grid(const JointBhm& m, double lo[3], std::int64_t n[3]) {
    for (int d = 0; d < 3; ++d) {
      lo[d] = m.lo_[d];
      n[d] = m.n_[d];
    }
  }
};

}  // namespace potmap::detail
