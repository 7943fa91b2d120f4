#pragma once
// An AveragedMap's whole state in a container payload (io/container_cursor.hpp), for mapper
// states and checkpoints: a map restored from it takes later scans bit for bit as the saved one
// would have.

#include "io/container_cursor.hpp"
#include "potmap/pot/averaged_map.hpp"

namespace potmap::detail {

struct AveragedMapState {
  static void write(ContainerWriter& w, const AveragedMap& m);
  /// Reads into `m`, which must have the saved map's dimension and options (checked: a
  /// mismatch fails naming the value found). The anchors' index is rebuilt from their places.
  static void read(ContainerCursor& c, AveragedMap& m);
};

}  // namespace potmap::detail
