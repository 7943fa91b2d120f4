#pragma once
// Shared helpers for the test suite.

#include <string>

#include "potmap/context.hpp"

namespace potmap::test {

/// The repository root (tests read ../shared/data relative to it).
std::string source_dir();
/// Path of a file under ../shared/data, e.g. shared_data("carla/town1_test2k.csv").
std::string shared_data(const std::string& rel);
/// A fresh empty folder under the build tree for one test's files.
std::string temp_dir(const std::string& name);
/// The Context every device test uses (POTMAP_DEVICE picks it; PoCL in CI).
Context& context();

}  // namespace potmap::test
