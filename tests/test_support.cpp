#include "test_support.hpp"

#include <filesystem>
#include <memory>

namespace fs = std::filesystem;

namespace potmap::test {

std::string source_dir() { return POTMAP_SOURCE_DIR; }

std::string shared_data(const std::string& rel) {
  return (fs::path(POTMAP_SOURCE_DIR) / ".." / "shared" / "data" / rel).lexically_normal().string();
}

std::string temp_dir(const std::string& name) {
  fs::path p = fs::path(POTMAP_BINARY_DIR) / "test-tmp" / name;
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

Context& context() {
  // One per test process: building programs costs seconds on PoCL, so tests share them.
  static std::unique_ptr<Context> ctx = std::make_unique<Context>();
  return *ctx;
}

}  // namespace potmap::test
