#include "test_support.hpp"

#include <cmath>

#include <array>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include <memory>

#include "potmap/data/drive.hpp"
#include "potmap/mapping/drive_mapper.hpp"

namespace fs = std::filesystem;

namespace potmap::test {

std::string source_dir() {
  return POTMAP_SOURCE_DIR;
}

std::shared_ptr<const Dictionary> drive_atoms(const std::string& drive, std::size_t keyframes) {
  const Drive d = open_drive(shared_data(drive));
  DriveMapperOptions o;
  o.range_cut = 20;
  DriveMapper src(o);
  std::vector<Scan> scans;
  for (std::size_t i = 0; i < keyframes; ++i) {
    const Scan k = read_keyframe(d, i);
    src.add(k, std::int64_t(i), &context());
    scans.push_back(limit_range(k, 20));
  }
  DictionaryOptions dopt;
  dopt.kernels_at_samples = 1;
  dopt.labels.free_per_metre = 0.5;
  dopt.max_weight_variance = 5;
  auto dict = std::make_shared<Dictionary>();
  build_dictionary(scans, src.map(), dopt, *dict);
  return dict;
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

bool small_inputs() {
  const char* v = std::getenv("POTMAP_TEST_INPUTS");
  return v && std::string(v) == "small";
}

bool cli_built() {
  return !std::string(POTMAP_CLI).empty();
}

std::string quoted(const std::string& s) {
  return "'" + s + "'";
}

std::pair<std::uint32_t, std::uint32_t> png_size(const std::string& path) {
  const std::string png = file_bytes(path);
  if (png.size() < 24 || png.compare(1, 3, "PNG") != 0) return {0, 0};
  auto be32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (int k = 0; k < 4; ++k) v = v << 8 | static_cast<unsigned char>(png[at + k]);
    return v;
  };
  return {be32(16), be32(20)};
}

std::string write_file(const std::string& dir, const std::string& name, const std::string& body) {
  const std::string p = dir + "/" + name;
  std::ofstream(p, std::ios::binary) << body;
  return p;
}

LabelledPoints training_samples(const Scan& scan, std::int64_t index, double free_per_metre) {
  LabelOptions o;
  o.holdout_fraction = 0;
  o.free_per_metre = free_per_metre;
  LabelledSplit s;
  label_scan(scan, index, o, s);
  return s.train;
}

std::string file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

KernelMap grid_around(const std::array<double, 3>& c, double half) {
  KernelMap map;
  map.dim = 2;
  for (double x = -half; x <= half + 1e-9; x += 2)
    for (double y = -half; y <= half + 1e-9; y += 2) {
      const double p[2] = {c[0] + x, c[1] + y};
      map.push_back(p, 2.0, 0.1 * static_cast<double>(map.size() % 17) - 0.8, 0.5);
    }
  return map;
}

MapperOptions small_mapper_options(bool refine) {
  constexpr double kPi = 3.14159265358979323846;
  // The paper's rules: the tests check the summed overall map and the barycentric placement.
  MapperOptions o = MapperOptions::paper();
  o.pot.rank_hits = 40;
  o.pot.rank_free = 20;
  o.pot.transport_points = 120;
  o.pot.transport_max_iterations = 600;
  o.pot.transport_tolerance = 1e-4;
  o.pot.rotations = {0, kPi / 2, kPi, 3 * kPi / 2};
  o.pot.refine = refine;
  o.labels.seed = o.pot.seed = 3;
  return o;
}

FileSizeLimit::FileSizeLimit(unsigned long long bytes) {
  rlimit r{};
  getrlimit(RLIMIT_FSIZE, &r);
  saved_cur_ = r.rlim_cur;
  saved_max_ = r.rlim_max;
  old_handler_ = std::signal(SIGXFSZ, SIG_IGN);
  r.rlim_cur = static_cast<rlim_t>(bytes);
  if (setrlimit(RLIMIT_FSIZE, &r) != 0) {
    std::signal(SIGXFSZ, old_handler_);
    throw std::runtime_error("setrlimit(RLIMIT_FSIZE) refused");
  }
}

FileSizeLimit::~FileSizeLimit() {
  rlimit r{};
  r.rlim_cur = static_cast<rlim_t>(saved_cur_);
  r.rlim_max = static_cast<rlim_t>(saved_max_);
  setrlimit(RLIMIT_FSIZE, &r);
  std::signal(SIGXFSZ, old_handler_);
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

void expect_same_map(const KernelMap& a, const KernelMap& b) {
  EXPECT_EQ(a.dim, b.dim);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a.position, b.position);  // operator== on doubles: exact
  EXPECT_EQ(a.gamma, b.gamma);
  EXPECT_EQ(a.w_mean, b.w_mean);
  EXPECT_EQ(a.w_var, b.w_var);
  EXPECT_EQ(a.has_bias, b.has_bias);
  EXPECT_EQ(a.bias_mean, b.bias_mean);
  EXPECT_EQ(a.bias_var, b.bias_var);
  EXPECT_EQ(a.cutoff_tau, b.cutoff_tau);
}

}  // namespace potmap::test
