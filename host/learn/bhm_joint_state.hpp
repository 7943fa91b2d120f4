#pragma once
// A JointBhm's whole state in a container payload (io/container_cursor.hpp), for mapper states
// and checkpoints: a learner restored from it continues bit for bit as the saved one would have.

#include "io/container_cursor.hpp"
#include "potmap/learn/bhm_joint.hpp"

namespace potmap::detail {

struct JointBhmState {
  static void write(ContainerWriter& w, const JointBhm& m);
  /// Reads into `m`, which must have been built with the saved learner's options (the grid,
  /// kernel width and tile size are checked: a mismatch fails naming the value found). Only
  /// scratch space is not saved; the rest, caches included, comes back as it was.
  static void read(ContainerCursor& c, JointBhm& m);
};

}  // namespace potmap::detail
