#pragma once
// Shared helpers for the test suite.

#include <string>

#include "potmap/pot/atoms.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap::test {

/// The repository root (tests read ../shared/data relative to it).
std::string source_dir();
/// Path of a file under ../shared/data, e.g. shared_data("carla/town1_test2k.csv").
std::string shared_data(const std::string& rel);
/// A fresh empty folder under the build tree for one test's files.
std::string temp_dir(const std::string& name);
/// Exit status and captured stdout of one run of the potmap command.
struct CliResult {
  int status = -1;
  std::string out;
};
/// Runs `potmap <args> <redirect>` through the shell (redirect e.g. "2>&1" or "2>/dev/null").
CliResult run_cli(const std::string& args, const std::string& redirect = "2>&1");
/// Whether the potmap command was built (POTMAP_BUILD_TOOLS).
bool cli_built();
/// Single-quotes a path for the shell.
std::string quoted(const std::string& s);
/// The whole file as bytes (empty when it cannot be read).
std::string file_bytes(const std::string& path);

/// The sector with its hits and free samples turned by `angle` radians about its origin (the
/// sector frame's centre), counter-clockwise (about the vertical axis in 3D).
Sector rotated_sector(const Sector& s, double angle);

/// 2D kernels every 2 m over a square of half-width `half` around `centre`, each weight mean
/// tagging its index: a source map for small dictionaries.
KernelMap kernel_grid_around(const std::array<double, 3>& centre, double half);

/// Mapper settings small enough for tests (fewer samples and rotations, seed 3), RePOT with
/// `refine`.
MapperOptions small_mapper_options(bool refine);

/// The Context every device test uses (POTMAP_DEVICE picks it; PoCL in CI).
Context& context();

}  // namespace potmap::test
