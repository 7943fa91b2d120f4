#pragma once
// Helpers for the C API tests. These tests use only potmap.h (and plain OpenCL), as an embedding
// program would; the reference values come from the model's formula computed here in double.

#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "potmap/potmap.h"

/// Expects POTMAP_SUCCESS, printing the status name and the last-error message otherwise.
#define POTMAP_ASSERT_OK(call)                                                               \
  do {                                                                                       \
    const potmap_status potmap_st_ = (call);                                                 \
    ASSERT_EQ(potmap_st_, POTMAP_SUCCESS)                                                    \
        << #call << ": " << potmap_status_string(potmap_st_) << ": " << potmap_last_error(); \
  } while (0)

/// Expects a given failure status and a non-empty last-error message naming the function.
#define POTMAP_EXPECT_FAIL(call, status)                                                           \
  do {                                                                                             \
    const potmap_status potmap_st_ = (call);                                                       \
    EXPECT_EQ(potmap_st_, status) << #call << " gave " << potmap_status_string(potmap_st_) << ": " \
                                  << potmap_last_error();                                          \
    EXPECT_NE(std::string(potmap_last_error()), "") << #call;                                      \
  } while (0)

namespace capi_test {

constexpr double kPi = 3.14159265358979323846;

/// One context for the tests that need no other (loading programs costs time on PoCL); made on
/// first use, kept until the process ends.
potmap_context* shared_context();

/// Whether needle occurs in hay.
bool contains(const std::string& hay, const std::string& needle);

/// Path of a file under ../shared/data.
std::string shared_data(const std::string& rel);
/// A fresh empty folder under the build tree.
std::string temp_dir(const std::string& name);
void write_text(const std::string& path, const std::string& text);

/// A random map as plain arrays (seeded, reproducible), kernels spread over [0, extent]^dim.
struct Arrays {
  int dim = 2;
  std::vector<double> position, gamma, w_mean, w_var;
  bool has_bias = false;
  double bias_mean = 0, bias_var = 0;
  std::size_t size() const { return gamma.size(); }
};
Arrays random_map(int dim, std::size_t count, std::uint64_t seed, double extent = 20.0);
/// n random points (n * dim doubles) over [-2, extent + 2]^dim.
std::vector<double> random_points(int dim, std::size_t n, std::uint64_t seed, double extent = 20.0);
/// The model (SPEC section 2) in double, every kernel, no cut-off.
struct Values {
  std::vector<double> mean, var, prob;
};
Values reference(const Arrays& map, const std::vector<double>& points);

/// A map handle made from arrays (test fails on error).
potmap_map* make_map(const Arrays& a);

/// The host's own OpenCL objects, made with plain OpenCL calls on the device potmap picks by
/// default (so POTMAP_DEVICE applies), released on destruction.
struct HostCl {
  cl_platform_id platform = nullptr;
  cl_device_id device = nullptr;
  cl_context context = nullptr;
  cl_command_queue queue = nullptr;
  HostCl();
  ~HostCl();
  HostCl(const HostCl&) = delete;
  HostCl& operator=(const HostCl&) = delete;
  /// A buffer of `bytes` in this context, filled from `data` if given (released by the caller).
  cl_mem buffer(std::size_t bytes, const void* data = nullptr) const;
  std::vector<float> read(cl_mem m, std::size_t count) const;
};

cl_uint reference_count(cl_context c);
cl_uint reference_count(cl_command_queue q);
cl_uint reference_count(cl_mem m);
cl_uint reference_count(cl_event e);

/// A simulated 2D scan of a small room (walls of [0, 12] x [0, 9] m and a pillar of [7, 8] x
/// [3, 6]), seen from (x, y) with heading yaw: `beams` beams over the full circle, ranges of
/// max_range or more are no-returns. Owns its arrays; scan() describes it for the C API (the
/// description points into them: keep the RoomScan alive while it is used).
struct RoomScan {
  double x = 0, y = 0, yaw = 0, max_range = 6;
  double timestamp = 0;  ///< seconds (the mappers' clock for forgetting)
  std::vector<double> hits, no_return;
  potmap_scan scan() const;
};
RoomScan room_scan(double x, double y, double yaw, int beams = 180, double max_range = 6);
/// `n` scans along a path through the room (x from 2 to 10 m, y around 2 m and 7 m).
std::vector<RoomScan> room_path(std::size_t n);
/// Pointers to each scan's description, for the calls taking `const potmap_scan* const*`.
struct ScanList {
  std::vector<potmap_scan> scans;
  std::vector<const potmap_scan*> ptrs;
  explicit ScanList(const std::vector<RoomScan>& room);
  const potmap_scan* const* data() const { return ptrs.data(); }
  std::size_t size() const { return ptrs.size(); }
};

}  // namespace capi_test
