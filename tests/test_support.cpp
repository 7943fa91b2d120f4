#include "test_support.hpp"

#include <cmath>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <sys/wait.h>
#include <unistd.h>
#include <memory>

namespace fs = std::filesystem;

namespace potmap::test {

std::string source_dir() {
  return POTMAP_SOURCE_DIR;
}

std::string shared_data(const std::string& rel) {
  return (fs::path(POTMAP_SOURCE_DIR) / ".." / "shared" / "data" / rel).lexically_normal().string();
}

std::string temp_dir(const std::string& name) {
  // One folder per process: ctest runs tests in parallel processes that may ask for one name.
  fs::path p = fs::path(POTMAP_BINARY_DIR) / "test-tmp" / (name + "-" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p.string();
}

CliResult run_cli(const std::string& args, const std::string& redirect) {
  const std::string cmd = quoted(POTMAP_CLI) + " " + args + " " + redirect;
  CliResult r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf;
  std::size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), p)) > 0) r.out.append(buf.data(), n);
  const int st = pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

bool cli_built() {
  return !std::string(POTMAP_CLI).empty();
}

std::string quoted(const std::string& s) {
  return "'" + s + "'";
}

std::string file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

Context& context() {
  // One per test process: building programs costs seconds on PoCL, so tests share them.
  static std::unique_ptr<Context> ctx = std::make_unique<Context>();
  return *ctx;
}

Sector rotated_sector(const Sector& s, double angle) {
  Sector r = s;
  const double c = std::cos(angle), sn = std::sin(angle);
  for (auto* v : {&r.hits, &r.free})
    for (std::size_t i = 0; i < v->size(); i += s.dim) {
      const double x = (*v)[i], y = (*v)[i + 1];
      (*v)[i] = c * x - sn * y;
      (*v)[i + 1] = sn * x + c * y;
    }
  return r;
}

}  // namespace potmap::test
