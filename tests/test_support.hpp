#pragma once
// Shared helpers for the test suite.

#include <gtest/gtest.h>

#include <array>
#include <initializer_list>
#include <memory>
#include <string>
#include <utility>

#include "potmap/data/labelling.hpp"
#include "potmap/error.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap::test {

constexpr double kPi = 3.14159265358979323846;

/// A drive's own dictionary: keyframes 0 to keyframes-1 of ../shared/data/`drive` mapped by
/// the joint BHM at a 20 m cut, cut into 20 m sectors, kernels at the atoms' samples every
/// metre (as a 3D dictionary is made).
std::shared_ptr<const Dictionary> drive_atoms(const std::string& drive, std::size_t keyframes);

/// The repository root (tests read ../shared/data relative to it).
std::string source_dir();
/// Path of a file under ../shared/data, e.g. shared_data("carla/town1_test2k.csv").
std::string shared_data(const std::string& rel);
/// A fresh empty folder under the build tree for one test's files.
std::string temp_dir(const std::string& name);
/// Writes `body` to dir/name (bytes as given) and returns the path.
std::string write_file(const std::string& dir, const std::string& name, const std::string& body);

/// Expects two maps equal in every field, bit for bit (a restored or re-read map).
void expect_same_map(const KernelMap& a, const KernelMap& b);

/// Runs f, expects a potmap::InputError whose message contains every needle.
template <class F>
void expect_input_error(F f, std::initializer_list<std::string> needles) {
  try {
    f();
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    const std::string m = e.what();
    for (const auto& n : needles) EXPECT_NE(m.find(n), std::string::npos) << m << " lacks " << n;
  }
}

/// Every beam's samples of `scan` (scan index `index`) as training samples, none held out,
/// `free_per_metre` free samples per metre of beam (default: LabelOptions').
LabelledPoints training_samples(const Scan& scan, std::int64_t index,
                                double free_per_metre = LabelOptions{}.free_per_metre);

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
/// Width and height of a PNG from its header ({0, 0} when it is not one).
std::pair<std::uint32_t, std::uint32_t> png_size(const std::string& path);

/// The sector with its hits and free samples turned by `angle` radians about its origin (the
/// sector frame's centre), counter-clockwise (about the vertical axis in 3D).
Sector rotated_sector(const Sector& s, double angle);

/// Kernels every 2 m over [c - half, c + half]^2, each weight mean tagging its index (so that a
/// test sees which kernels a transport moved where): a source map for small dictionaries.
KernelMap grid_around(const std::array<double, 3>& c, double half);

/// Mapper options small enough for tests (40 + 20 ranked samples, 120 transport points, four
/// rotations, seed 3) on the paper's rules (MapperOptions::paper()): a scan maps in a fraction
/// of a second on PoCL.
MapperOptions small_mapper_options(bool refine);

/// While alive, no file of this process can grow past `bytes`: the kernel fails a write beyond
/// (EFBIG, as ENOSPC on a full disk), whoever writes. SIGXFSZ, which would kill the process, is
/// ignored meanwhile. The limit is the process's: nothing else may write files while it lives.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(unsigned long long bytes);  ///< throws std::runtime_error if refused
  ~FileSizeLimit();
  FileSizeLimit(const FileSizeLimit&) = delete;
  FileSizeLimit& operator=(const FileSizeLimit&) = delete;

 private:
  unsigned long long saved_cur_ = 0, saved_max_ = 0;
  void (*old_handler_)(int) = nullptr;
};

/// Whether this run asks for small inputs: POTMAP_TEST_INPUTS=small, which the sanitizer runs
/// set (scripts/sanitize_suite.sh). Instrumented, the library runs 3 to 30 times slower, so the
/// tests that map whole logs or thousands of atoms take fewer scans, atoms or points there;
/// their bars at that size are measured too (each test says its numbers at both sizes).
bool small_inputs();
/// `full` in a normal run, `small` when small_inputs().
template <class T>
T sized(T full, T small) {
  return small_inputs() ? small : full;
}

/// The Context every device test uses (POTMAP_DEVICE picks it; PoCL in CI).
Context& context();

}  // namespace potmap::test
