#pragma once
// Maps in flight between MPI ranks: a rank's overall map as the bytes of the .potmap file that
// carries what merging needs (learn/bhm_joint_merge.hpp), and such bytes read back on rank 0.
// The bytes pass through a temporary file of the process's own (the library reads and writes
// map files), removed at once.
#include <functional>
#include <optional>
#include <string>

#include "potmap/learn/bhm_joint.hpp"
#include "potmap/pot/averaged_map.hpp"

namespace potmap::job {

/// The bytes of the .potmap file `write` writes to the path it is given.
std::string potmap_bytes(const std::function<void(const std::string& path)>& write);

/// A map received as bytes, with what merging needs.
struct ReceivedMap {
  std::optional<JointBhm> joint;
  std::optional<AveragedMap> averaged;
};

/// Reads the .potmap `bytes` sent by `from` ("rank 2"). Throws InputError naming `from` for
/// bytes that are not a map with an information form or averaged sums.
ReceivedMap read_potmap_bytes(const std::string& bytes, const std::string& from);

}  // namespace potmap::job
