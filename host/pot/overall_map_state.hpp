#pragma once
// An OverallMap's whole state in a container payload (io/container_cursor.hpp), for mapper
// states and checkpoints: a map restored from it merges later scans bit for bit as the saved
// one would have.

#include "io/container_cursor.hpp"
#include "potmap/pot/overall_map.hpp"

namespace potmap::detail {

struct OverallMapState {
  static void write(ContainerWriter& w, const OverallMap& m);
  /// Reads into `m`, which must have the saved map's dimension and options (checked: a
  /// mismatch fails naming the value found). The spatial index is rebuilt from the kernels: it
  /// holds the same kernels per cell (the order within a cell never changes a result).
  static void read(ContainerCursor& c, OverallMap& m);
};

}  // namespace potmap::detail
