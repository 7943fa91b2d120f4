#pragma once
// A JointBhm's whole state in a container payload (io/container_cursor.hpp), for mapper states
// and checkpoints: a learner restored from it continues bit for bit as the saved one would have.

#include "io/container_cursor.hpp"
#include "potmap/learn/bhm_joint.hpp"

namespace potmap::detail {

struct JointBhmState {
  /// Writes each kernel's half stencil (JointBhm::HalfRun). `full_stencil`: the whole stencil's
  /// box instead, as states were saved before the half (a test's way to check they still read).
  static void write(ContainerWriter& w, const JointBhm& m, bool full_stencil = false);
  /// Reads into `m`, which must have been built with the saved learner's options (the grid,
  /// kernel width and tile size are checked: a mismatch fails naming the value found). Only
  /// scratch space is not saved; the rest, caches included, comes back as it was. A state with
  /// the whole stencil (saved before the half) reads too: its half is taken (P is symmetric).
  static void read(ContainerCursor& c, JointBhm& m);
  /// The retired tiles (JointBhm::retire_far()), which write() leaves out (the states of the
  /// mappers that never retire keep their layout): coordinates, means and variances.
  static void write_retired(ContainerWriter& w, const JointBhm& m);
  static void read_retired(ContainerCursor& c, JointBhm& m);
  /// The data fingerprints (JointBhm::data_ids()), which write() leaves out too: states end
  /// with them, and a state saved before them ends earlier, so read_data_ids() reads them only
  /// when bytes are left before the checksum (none: the learner records no earlier scan).
  static void write_data_ids(ContainerWriter& w, const JointBhm& m);
  static void read_data_ids(ContainerCursor& c, JointBhm& m);
  /// The forgetting clock (JointBhm::set_time(): the time, whether it was set, each stored and
  /// retired tile's fading time), after the data fingerprints; a state saved before it ends
  /// earlier and restores a learner whose tiles are all up to date at time 0.
  static void write_clock(ContainerWriter& w, const JointBhm& m);
  static void read_clock(ContainerCursor& c, JointBhm& m);
};

}  // namespace potmap::detail
