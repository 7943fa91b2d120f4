// The C API on host arrays: status codes, messages, maps, evaluation and every error path.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "capi_test_support.hpp"

using namespace capi_test;

extern "C" int potmap_c99_check(void);

TEST(CApi, HeaderIsPlainC99) {
  EXPECT_EQ(potmap_c99_check(), 0) << "c99_check.c: the check at that line failed";
}

TEST(CApi, VersionMatchesHeaders) {
  int major = -1, minor = -1, patch = -1;
  POTMAP_ASSERT_OK(potmap_version(&major, &minor, &patch));
  EXPECT_EQ(major, POTMAP_VERSION_MAJOR);
  EXPECT_EQ(minor, POTMAP_VERSION_MINOR);
  EXPECT_EQ(patch, POTMAP_VERSION_PATCH);
  EXPECT_EQ(POTMAP_VERSION, major * 10000 + minor * 100 + patch);
  EXPECT_STREQ(potmap_version_string(), POTMAP_VERSION_STRING);
  POTMAP_ASSERT_OK(potmap_version(nullptr, nullptr, nullptr));
}

TEST(CApi, StatusStringsAreDistinct) {
  const potmap_status own[] = {POTMAP_SUCCESS,
                               POTMAP_ERROR_NULL_ARGUMENT,
                               POTMAP_ERROR_INVALID_HANDLE,
                               POTMAP_ERROR_INVALID_ARGUMENT,
                               POTMAP_ERROR_DIMENSION_MISMATCH,
                               POTMAP_ERROR_BUFFER_TOO_SMALL,
                               POTMAP_ERROR_CONTEXT_MISMATCH,
                               POTMAP_ERROR_INPUT,
                               POTMAP_ERROR_IO,
                               POTMAP_ERROR_NO_DEVICE,
                               POTMAP_ERROR_OUT_OF_MEMORY,
                               POTMAP_ERROR_INTERNAL,
                               POTMAP_ERROR_CANCELLED};
  std::set<std::string> names;
  for (potmap_status s : own) {
    const std::string name = potmap_status_string(s);
    EXPECT_EQ(name.rfind("POTMAP_", 0), 0u) << s;
    EXPECT_NE(name, "POTMAP_UNKNOWN_STATUS") << s;
    names.insert(name);
    if (s != POTMAP_SUCCESS) EXPECT_GT(s, 0) << "potmap's codes never collide with OpenCL's";
  }
  EXPECT_EQ(names.size(), std::size(own));
  EXPECT_STREQ(potmap_status_string(CL_OUT_OF_RESOURCES), "CL_OUT_OF_RESOURCES");
  EXPECT_STREQ(potmap_status_string(CL_BUILD_PROGRAM_FAILURE), "CL_BUILD_PROGRAM_FAILURE");
  EXPECT_STREQ(potmap_status_string(CL_INVALID_MEM_OBJECT), "CL_INVALID_MEM_OBJECT");
  EXPECT_STREQ(potmap_status_string(-12345), "POTMAP_UNKNOWN_STATUS");
  EXPECT_STREQ(potmap_status_string(POTMAP_SUCCESS), "POTMAP_SUCCESS");
  EXPECT_STREQ(potmap_status_string(POTMAP_ERROR_NULL_ARGUMENT), "POTMAP_ERROR_NULL_ARGUMENT");
  EXPECT_STREQ(potmap_status_string(POTMAP_ERROR_IO), "POTMAP_ERROR_IO");
  EXPECT_STREQ(potmap_status_string(POTMAP_ERROR_INTERNAL), "POTMAP_ERROR_INTERNAL");
  EXPECT_STREQ(potmap_status_string(POTMAP_ERROR_CANCELLED), "POTMAP_ERROR_CANCELLED");
  EXPECT_STREQ(potmap_status_string(static_cast<potmap_status>(1013)), "POTMAP_UNKNOWN_STATUS");
  EXPECT_STREQ(potmap_status_string(77), "POTMAP_UNKNOWN_STATUS");
}

TEST(CApi, LastErrorIsPerThreadAndClearedOnSuccess) {
  potmap_map* map = nullptr;
  POTMAP_EXPECT_FAIL(potmap_map_create(4, 0, nullptr, nullptr, nullptr, nullptr, &map),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  const std::string msg = potmap_last_error();
  EXPECT_TRUE(contains(msg, "potmap_map_create")) << msg;
  EXPECT_TRUE(contains(msg, "4")) << msg;
  std::string other = "unset";
  std::thread([&] { other = potmap_last_error(); }).join();
  EXPECT_EQ(other, "");
  EXPECT_EQ(std::string(potmap_last_error()), msg) << "reading it does not clear it";
  POTMAP_ASSERT_OK(potmap_map_create(2, 0, nullptr, nullptr, nullptr, nullptr, &map));
  EXPECT_STREQ(potmap_last_error(), "");
  potmap_map_destroy(map);
}

TEST(CApi, NullHandlesAndOutPointers) {
  const Arrays a = random_map(2, 3, 1);
  potmap_map* map = make_map(a);
  potmap_context* ctx = shared_context();
  ASSERT_NE(ctx, nullptr);
  potmap_evaluator* ev = nullptr;
  POTMAP_ASSERT_OK(potmap_evaluator_create(ctx, map, 0, &ev));
  const double pt[2] = {1, 1};
  float out[1] = {0};
  int dim = 0;
  size_t count = 0;
  double d = 0;
  const double origin[3] = {0, 0, 0};
  const size_t cells[3] = {1, 1, 1};
  const potmap_device_info* info = nullptr;

  // Null out-pointers of create/load calls.
  POTMAP_EXPECT_FAIL(potmap_context_create(nullptr, nullptr), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_create(2, 1, a.position.data(), a.gamma.data(), a.w_mean.data(),
                                       a.w_var.data(), nullptr),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_load(shared_data("carla/town1_abhm_map.csv").c_str(), nullptr),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_evaluator_create(ctx, map, 0, nullptr), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_context_device_info(ctx, nullptr), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_size(map, nullptr, &count), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_size(map, &dim, nullptr), POTMAP_ERROR_NULL_ARGUMENT);
  // Null input arrays and paths.
  potmap_map* never = reinterpret_cast<potmap_map*>(0x1);
  POTMAP_EXPECT_FAIL(
      potmap_map_create(2, 1, nullptr, a.gamma.data(), a.w_mean.data(), a.w_var.data(), &never),
      POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(
      potmap_map_create(2, 1, a.position.data(), a.gamma.data(), nullptr, a.w_var.data(), &never),
      POTMAP_ERROR_NULL_ARGUMENT);
  EXPECT_EQ(never, reinterpret_cast<potmap_map*>(0x1)) << "*out untouched on failure";
  POTMAP_EXPECT_FAIL(potmap_map_load(nullptr, &never), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_save(map, nullptr), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_read(map, nullptr, 0, nullptr, nullptr, nullptr, 0),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_evaluate(ev, nullptr, 1, 2, out, nullptr, nullptr, 1),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_evaluate(ev, pt, 1, 2, nullptr, nullptr, nullptr, 1),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_evaluate_grid(ev, 2, nullptr, 1.0, cells, out, nullptr, nullptr, 1),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_evaluate_grid(ev, 2, origin, 1.0, nullptr, out, nullptr, nullptr, 1),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_context_create_from_queue(nullptr, &ctx), POTMAP_ERROR_NULL_ARGUMENT);

  // Null handles.
  POTMAP_EXPECT_FAIL(potmap_context_device_info(nullptr, &info), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_context_cl(nullptr, nullptr, nullptr, nullptr),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_save(nullptr, "x.csv"), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_size(nullptr, &dim, &count), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_read(nullptr, &d, 1, nullptr, nullptr, nullptr, 0),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_set_bias(nullptr, 1, 0, 0), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_bias(nullptr, nullptr, nullptr, nullptr),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_set_cutoff(nullptr, 4.5), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_cutoff(nullptr, nullptr), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_evaluator_create(nullptr, map, 0, &ev), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_evaluator_create(ctx, nullptr, 0, &ev), POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_evaluate(nullptr, pt, 1, 2, out, nullptr, nullptr, 1),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_evaluate_grid(nullptr, 2, origin, 1, cells, out, nullptr, nullptr, 1),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_evaluate_device(nullptr, nullptr, 0, 2, nullptr, nullptr, nullptr,
                                            nullptr, 0, nullptr, nullptr),
                     POTMAP_ERROR_NULL_ARGUMENT);
  // Destroying null is a no-op, like free().
  POTMAP_ASSERT_OK(potmap_context_destroy(nullptr));
  POTMAP_ASSERT_OK(potmap_map_destroy(nullptr));
  POTMAP_ASSERT_OK(potmap_evaluator_destroy(nullptr));

  POTMAP_ASSERT_OK(potmap_evaluator_destroy(ev));
  POTMAP_ASSERT_OK(potmap_map_destroy(map));
}

TEST(CApi, HandleOfWrongTypeIsRefused) {
  potmap_map* map = make_map(random_map(2, 2, 2));
  auto* as_evaluator = reinterpret_cast<potmap_evaluator*>(map);
  auto* as_context = reinterpret_cast<potmap_context*>(map);
  float out[1];
  const double pt[2] = {0, 0};
  POTMAP_EXPECT_FAIL(potmap_evaluate(as_evaluator, pt, 1, 2, out, nullptr, nullptr, 1),
                     POTMAP_ERROR_INVALID_HANDLE);
  POTMAP_EXPECT_FAIL(potmap_evaluator_destroy(as_evaluator), POTMAP_ERROR_INVALID_HANDLE);
  potmap_evaluator* ev = nullptr;
  POTMAP_EXPECT_FAIL(potmap_evaluator_create(as_context, map, 0, &ev), POTMAP_ERROR_INVALID_HANDLE);
  POTMAP_EXPECT_FAIL(potmap_context_destroy(as_context), POTMAP_ERROR_INVALID_HANDLE);
  int dim = 0;
  size_t n = 0;
  POTMAP_ASSERT_OK(potmap_map_size(map, &dim, &n));  // the map itself is untouched
  EXPECT_EQ(n, 2u);
  POTMAP_ASSERT_OK(potmap_map_destroy(map));
}

// Reading a freed handle is what this checks, so a sanitizer build must report it instead.
#if defined(__SANITIZE_ADDRESS__)
#define POTMAP_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define POTMAP_TEST_ASAN 1
#endif
#endif

TEST(CApi, UseAfterDestroyIsDetected) {
#ifdef POTMAP_TEST_ASAN
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH(
      {
        potmap_map* map = make_map(random_map(2, 2, 3));
        potmap_map_destroy(map);
        int dim = 0;
        size_t n = 0;
        potmap_map_size(map, &dim, &n);
      },
      "heap-use-after-free");
#else
  // Best effort (documented): the tag is cleared on destroy; nothing is allocated in between
  // here, so the freed block still holds the cleared tag or allocator bookkeeping.
  potmap_map* map = make_map(random_map(2, 2, 3));
  POTMAP_ASSERT_OK(potmap_map_destroy(map));
  int dim = 0;
  size_t n = 0;
  POTMAP_EXPECT_FAIL(potmap_map_size(map, &dim, &n), POTMAP_ERROR_INVALID_HANDLE);
  POTMAP_EXPECT_FAIL(potmap_map_destroy(map), POTMAP_ERROR_INVALID_HANDLE);
  EXPECT_TRUE(contains(potmap_last_error(), "destroyed")) << potmap_last_error();
#endif
}

TEST(CApi, MapCreateChecksEveryValue) {
  Arrays a = random_map(3, 5, 4);
  potmap_map* map = nullptr;
  POTMAP_EXPECT_FAIL(potmap_map_create(1, a.size(), a.position.data(), a.gamma.data(),
                                       a.w_mean.data(), a.w_var.data(), &map),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  a.gamma[3] = -0.5;
  POTMAP_EXPECT_FAIL(potmap_map_create(3, a.size(), a.position.data(), a.gamma.data(),
                                       a.w_mean.data(), a.w_var.data(), &map),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "3")) << "names the kernel: " << potmap_last_error();
  EXPECT_TRUE(contains(potmap_last_error(), "-0.5")) << potmap_last_error();
  a.gamma[3] = 1.0;
  a.w_var[1] = -1.0;
  POTMAP_EXPECT_FAIL(potmap_map_create(3, a.size(), a.position.data(), a.gamma.data(),
                                       a.w_mean.data(), a.w_var.data(), &map),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  a.w_var[1] = 1.0;
  a.position[7] = NAN;
  POTMAP_EXPECT_FAIL(potmap_map_create(3, a.size(), a.position.data(), a.gamma.data(),
                                       a.w_mean.data(), a.w_var.data(), &map),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_EQ(map, nullptr);
  a.position[7] = 1.0;
  POTMAP_ASSERT_OK(potmap_map_create(3, a.size(), a.position.data(), a.gamma.data(),
                                     a.w_mean.data(), a.w_var.data(), &map));
  POTMAP_EXPECT_FAIL(potmap_map_set_bias(map, 1, NAN, 1.0), POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_set_bias(map, 1, 0.0, -1.0), POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_ASSERT_OK(potmap_map_destroy(map));
}

TEST(CApi, MapRoundTripsThroughEveryFormat) {
  Arrays a = random_map(3, 40, 5);
  a.has_bias = true;
  a.bias_mean = -0.75;
  a.bias_var = 0.125;
  potmap_map* map = make_map(a);
  double tau = 0;
  POTMAP_ASSERT_OK(potmap_map_cutoff(map, &tau));
  EXPECT_TRUE(std::isinf(tau));  // a new map has none
  POTMAP_EXPECT_FAIL(potmap_map_set_cutoff(map, 0.0), POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_map_set_cutoff(map, NAN), POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_ASSERT_OK(potmap_map_set_cutoff(map, 4.5));
  const std::string dir = temp_dir("roundtrip");
  for (const char* ext : {".csv", ".npz", ".potmap"}) {
    const std::string path = dir + "/map" + ext;
    POTMAP_ASSERT_OK(potmap_map_save(map, path.c_str()));
    potmap_map* back = nullptr;
    POTMAP_ASSERT_OK(potmap_map_load(path.c_str(), &back));
    int dim = 0;
    size_t n = 0;
    POTMAP_ASSERT_OK(potmap_map_size(back, &dim, &n));
    ASSERT_EQ(dim, 3) << ext;
    ASSERT_EQ(n, a.size()) << ext;
    std::vector<double> pos(n * 3), g(n), wm(n), wv(n);
    POTMAP_ASSERT_OK(
        potmap_map_read(back, pos.data(), pos.size(), g.data(), wm.data(), wv.data(), n));
    EXPECT_EQ(pos, a.position) << ext;
    EXPECT_EQ(g, a.gamma) << ext;
    EXPECT_EQ(wm, a.w_mean) << ext;
    EXPECT_EQ(wv, a.w_var) << ext;
    int has_bias = 0;
    double bm = 0, bv = 0;
    POTMAP_ASSERT_OK(potmap_map_bias(back, &has_bias, &bm, &bv));
    EXPECT_EQ(has_bias, 1) << ext;
    EXPECT_EQ(bm, a.bias_mean) << ext;
    EXPECT_EQ(bv, a.bias_var) << ext;
    POTMAP_ASSERT_OK(potmap_map_cutoff(back, &tau));
    EXPECT_EQ(tau, 4.5) << ext;
    // Too small: an error, and nothing written.
    std::vector<double> small(n - 1, 42.0);
    POTMAP_EXPECT_FAIL(potmap_map_read(back, nullptr, 0, small.data(), nullptr, nullptr, n - 1),
                       POTMAP_ERROR_BUFFER_TOO_SMALL);
    EXPECT_EQ(small, std::vector<double>(n - 1, 42.0));
    std::vector<double> small_pos(n * 3 - 1);
    POTMAP_EXPECT_FAIL(
        potmap_map_read(back, small_pos.data(), small_pos.size(), nullptr, nullptr, nullptr, 0),
        POTMAP_ERROR_BUFFER_TOO_SMALL);
    POTMAP_ASSERT_OK(potmap_map_destroy(back));
  }
  POTMAP_ASSERT_OK(potmap_map_set_bias(map, 0, 5.0, 5.0));
  int has_bias = 1;
  double bm = 1, bv = 1;
  POTMAP_ASSERT_OK(potmap_map_bias(map, &has_bias, &bm, &bv));
  EXPECT_EQ(has_bias, 0);
  EXPECT_EQ(bm, 0.0);
  EXPECT_EQ(bv, 0.0);
  POTMAP_ASSERT_OK(potmap_map_destroy(map));
}

TEST(CApi, BadFilesNameFileLineAndValue) {
  const std::string dir = temp_dir("badfiles");
  potmap_map* map = nullptr;
  const std::string missing = dir + "/missing.csv";
  POTMAP_EXPECT_FAIL(potmap_map_load(missing.c_str(), &map), POTMAP_ERROR_INPUT);
  EXPECT_TRUE(contains(potmap_last_error(), missing)) << potmap_last_error();

  const std::string bad = dir + "/bad.csv";
  write_text(bad, "x,y,gamma,w_mean,w_var\n1,2,0.5,1,0.1\n3,4,zebra,1,0.1\n");
  POTMAP_EXPECT_FAIL(potmap_map_load(bad.c_str(), &map), POTMAP_ERROR_INPUT);
  const std::string msg = potmap_last_error();
  EXPECT_TRUE(contains(msg, bad)) << msg;
  EXPECT_TRUE(contains(msg, "3")) << "line 3: " << msg;
  EXPECT_TRUE(contains(msg, "zebra")) << msg;

  const std::string truncated = dir + "/cut.potmap";
  write_text(truncated, "POTMAP\r\n\x01\x00\x00\x00");
  POTMAP_EXPECT_FAIL(potmap_map_load(truncated.c_str(), &map), POTMAP_ERROR_INPUT);
  const std::string unknown = dir + "/map.txt";
  write_text(unknown, "x,y,gamma,w_mean,w_var\n");
  POTMAP_EXPECT_FAIL(potmap_map_load(unknown.c_str(), &map), POTMAP_ERROR_INPUT);
  EXPECT_EQ(map, nullptr);

  potmap_map* good = make_map(random_map(2, 3, 6));
  POTMAP_EXPECT_FAIL(potmap_map_save(good, (dir + "/map.txt").c_str()),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  // A folder cannot be made under a file (a missing folder is made: not a failure).
  write_text(dir + "/a-file", "x");
  POTMAP_EXPECT_FAIL(potmap_map_save(good, (dir + "/a-file/folder/map.csv").c_str()),
                     POTMAP_ERROR_IO);
  POTMAP_ASSERT_OK(potmap_map_destroy(good));
}

TEST(CApi, ContextOnNamedDevice) {
  potmap_context* ctx = nullptr;
  POTMAP_EXPECT_FAIL(potmap_context_create("no-such-device-xyz", &ctx), POTMAP_ERROR_NO_DEVICE);
  EXPECT_TRUE(contains(potmap_last_error(), "no-such-device-xyz")) << potmap_last_error();
  EXPECT_EQ(ctx, nullptr);

  const potmap_device_info* info = nullptr;
  POTMAP_ASSERT_OK(potmap_context_device_info(shared_context(), &info));
  ASSERT_NE(info, nullptr);
  EXPECT_STRNE(info->name, "");
  EXPECT_STRNE(info->platform, "");
  EXPECT_GT(info->compute_units, 0u);
  EXPECT_GT(info->max_alloc_bytes, 0u);
  EXPECT_EQ(info->is_gpu + info->is_cpu <= 2, true);
  // The same device found again by a substring of its name.
  const std::string name = info->name;
  POTMAP_ASSERT_OK(potmap_context_create(name.substr(0, 6).c_str(), &ctx));
  const potmap_device_info* again = nullptr;
  POTMAP_ASSERT_OK(potmap_context_device_info(ctx, &again));
  EXPECT_EQ(std::string(again->name), name);
  cl_context cx = nullptr;
  cl_device_id dev = nullptr;
  cl_command_queue q = nullptr;
  POTMAP_ASSERT_OK(potmap_context_cl(ctx, &cx, &dev, &q));
  EXPECT_NE(cx, nullptr);
  EXPECT_NE(dev, nullptr);
  EXPECT_NE(q, nullptr);
  POTMAP_ASSERT_OK(potmap_context_destroy(ctx));
}

TEST(CApi, EvaluateMatchesTheModel) {
  for (int dim : {2, 3}) {
    Arrays a = random_map(dim, 200, 10 + dim);
    a.has_bias = true;
    a.bias_mean = 0.3;
    a.bias_var = 0.05;
    potmap_map* map = make_map(a);
    potmap_evaluator* ev = nullptr;
    POTMAP_ASSERT_OK(potmap_evaluator_create(shared_context(), map, 0, &ev));
    // The evaluator holds its own copy: the map may go first.
    POTMAP_ASSERT_OK(potmap_map_destroy(map));
    const std::size_t n = 500;
    const std::vector<double> pts = random_points(dim, n, 20 + dim);
    const Values want = reference(a, pts);
    std::vector<float> mean(n), var(n), prob(n);
    POTMAP_ASSERT_OK(
        potmap_evaluate(ev, pts.data(), n, dim, mean.data(), var.data(), prob.data(), n));
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_NEAR(prob[i], want.prob[i], 1e-5) << dim << "D point " << i;
      ASSERT_NEAR(var[i], want.var[i], 1e-4 * (1 + want.var[i])) << dim << "D point " << i;
      ASSERT_NEAR(mean[i], want.mean[i], 1e-4 * (1 + std::fabs(want.mean[i]))) << i;
    }
    // Probability alone; capacity larger than n is fine.
    std::vector<float> prob_only(n + 10, -1.f);
    POTMAP_ASSERT_OK(potmap_evaluate(ev, pts.data(), n, dim, nullptr, nullptr, prob_only.data(),
                                     prob_only.size()));
    EXPECT_TRUE(std::equal(prob.begin(), prob.end(), prob_only.begin()));
    EXPECT_EQ(prob_only[n], -1.f);
    POTMAP_ASSERT_OK(potmap_evaluator_destroy(ev));
  }
}

TEST(CApi, EvaluateRefusesWrongDimensionAndSmallBuffers) {
  const Arrays a = random_map(2, 20, 30);
  potmap_map* map = make_map(a);
  potmap_evaluator* ev = nullptr;
  POTMAP_EXPECT_FAIL(potmap_evaluator_create(shared_context(), map, -1.0, &ev),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_evaluator_create(shared_context(), map, NAN, &ev),
                     POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_ASSERT_OK(potmap_evaluator_create(shared_context(), map, 12.0, &ev));
  const std::size_t n = 10;
  const std::vector<double> pts = random_points(3, n, 31);  // enough doubles for 3D too
  std::vector<float> prob(n, -1.f), var(n - 1, -1.f);
  POTMAP_EXPECT_FAIL(potmap_evaluate(ev, pts.data(), n, 3, nullptr, nullptr, prob.data(), n),
                     POTMAP_ERROR_DIMENSION_MISMATCH);
  EXPECT_TRUE(contains(potmap_last_error(), "3D")) << potmap_last_error();
  POTMAP_EXPECT_FAIL(potmap_evaluate(ev, pts.data(), n, 2, nullptr, var.data(), prob.data(), n - 1),
                     POTMAP_ERROR_BUFFER_TOO_SMALL);
  EXPECT_EQ(prob, std::vector<float>(n, -1.f)) << "nothing written on failure";
  EXPECT_EQ(var, std::vector<float>(n - 1, -1.f));
  POTMAP_ASSERT_OK(potmap_evaluate(ev, nullptr, 0, 2, nullptr, nullptr, prob.data(), 0));

  const double origin[3] = {0, 0, 0};
  const size_t cells[3] = {4, 5, 7};
  std::vector<float> grid(20);
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_grid(ev, 3, origin, 1.0, cells, nullptr, nullptr, grid.data(), grid.size()),
      POTMAP_ERROR_DIMENSION_MISMATCH);
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_grid(ev, 2, origin, 1.0, cells, nullptr, nullptr, grid.data(), 19),
      POTMAP_ERROR_BUFFER_TOO_SMALL);
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_grid(ev, 2, origin, -1.0, cells, nullptr, nullptr, grid.data(), grid.size()),
      POTMAP_ERROR_INVALID_ARGUMENT);
  const size_t huge[3] = {SIZE_MAX / 2, SIZE_MAX / 2, 1};
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_grid(ev, 2, origin, 1.0, huge, nullptr, nullptr, grid.data(), grid.size()),
      POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_ASSERT_OK(potmap_evaluator_destroy(ev));
  POTMAP_ASSERT_OK(potmap_map_destroy(map));
}

TEST(CApi, GridMatchesPointEvaluation) {
  const Arrays a = random_map(2, 60, 40, 10.0);
  potmap_map* map = make_map(a);
  potmap_evaluator* ev = nullptr;
  POTMAP_ASSERT_OK(potmap_evaluator_create(shared_context(), map, 0, &ev));
  const double origin[3] = {-1.0, -2.0, 0.0};
  const size_t count[3] = {30, 17, 99};  // count[2] is ignored in 2D
  const double res = 0.5;
  std::vector<double> pts;
  for (size_t j = 0; j < count[1]; ++j)
    for (size_t i = 0; i < count[0]; ++i) {
      pts.push_back(origin[0] + (i + 0.5) * res);
      pts.push_back(origin[1] + (j + 0.5) * res);
    }
  const Values want = reference(a, pts);
  std::vector<float> prob(pts.size() / 2);
  POTMAP_ASSERT_OK(
      potmap_evaluate_grid(ev, 2, origin, res, count, nullptr, nullptr, prob.data(), prob.size()));
  for (size_t c = 0; c < prob.size(); ++c) ASSERT_NEAR(prob[c], want.prob[c], 1e-5) << c;
  POTMAP_ASSERT_OK(potmap_evaluator_destroy(ev));
  POTMAP_ASSERT_OK(potmap_map_destroy(map));
}

TEST(CApi, HandlesMayBeDestroyedInAnyOrder) {
  potmap_context* ctx = nullptr;
  POTMAP_ASSERT_OK(potmap_context_create(nullptr, &ctx));
  const Arrays a = random_map(2, 30, 50);
  potmap_map* map = make_map(a);
  potmap_evaluator* ev = nullptr;
  POTMAP_ASSERT_OK(potmap_evaluator_create(ctx, map, 0, &ev));
  POTMAP_ASSERT_OK(potmap_context_destroy(ctx));  // the evaluator keeps the device objects
  POTMAP_ASSERT_OK(potmap_map_destroy(map));
  const std::vector<double> pts = random_points(2, 16, 51);
  const Values want = reference(a, pts);
  std::vector<float> prob(16);
  POTMAP_ASSERT_OK(potmap_evaluate(ev, pts.data(), 16, 2, nullptr, nullptr, prob.data(), 16));
  for (size_t i = 0; i < 16; ++i) EXPECT_NEAR(prob[i], want.prob[i], 1e-5) << i;
  POTMAP_ASSERT_OK(potmap_evaluator_destroy(ev));
}

TEST(CApi, HeightBandIsTheMaximumOverItsHeights) {
  const Arrays a = random_map(3, 200, 41);
  potmap_map* map = make_map(a);
  potmap_evaluator* ev = nullptr;
  POTMAP_ASSERT_OK(potmap_evaluator_create(shared_context(), map, 0.0, &ev));
  const double origin[2] = {-1.0, 0.5};
  const size_t count[2] = {23, 19};
  const std::size_t n = count[0] * count[1];
  std::vector<float> mean(n), var(n), prob(n);
  // 2 to 8 m every 0.5 m at most: 13 heights, both ends included.
  POTMAP_ASSERT_OK(potmap_evaluate_band(ev, origin, 1.0, count, 2.0, 8.0, 0.5, mean.data(),
                                        var.data(), prob.data(), n));
  std::vector<double> best(n, -1.0);
  for (int k = 0; k <= 12; ++k) {
    std::vector<double> pts;
    for (std::size_t j = 0; j < count[1]; ++j)
      for (std::size_t i = 0; i < count[0]; ++i)
        pts.insert(pts.end(), {origin[0] + i + 0.5, origin[1] + j + 0.5, 2.0 + 0.5 * k});
    const Values ref = reference(a, pts);
    for (std::size_t c = 0; c < n; ++c) best[c] = std::max(best[c], ref.prob[c]);
  }
  for (std::size_t c = 0; c < n; ++c) ASSERT_NEAR(prob[c], best[c], 1e-6) << c;
  // step 0: the map's own default; prob alone.
  std::vector<float> p0(n, -1.f);
  POTMAP_ASSERT_OK(
      potmap_evaluate_band(ev, origin, 1.0, count, 2.0, 8.0, 0.0, nullptr, nullptr, p0.data(), n));
  EXPECT_GE(*std::min_element(p0.begin(), p0.end()), 0.f);
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_band(ev, origin, 1.0, count, 8.0, 2.0, 0.5, nullptr, nullptr, p0.data(), n),
      POTMAP_ERROR_INVALID_ARGUMENT);
  EXPECT_TRUE(contains(potmap_last_error(), "above")) << potmap_last_error();
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_band(ev, origin, 1.0, count, 2.0, 8.0, -1.0, nullptr, nullptr, p0.data(), n),
      POTMAP_ERROR_INVALID_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_evaluate_band(ev, origin, 1.0, count, 2.0, 8.0, 0.5, nullptr, nullptr,
                                          p0.data(), n - 1),
                     POTMAP_ERROR_BUFFER_TOO_SMALL);
  POTMAP_ASSERT_OK(potmap_evaluator_destroy(ev));
  POTMAP_ASSERT_OK(potmap_map_destroy(map));
  // A 2D map has no heights.
  map = make_map(random_map(2, 5, 42));
  POTMAP_ASSERT_OK(potmap_evaluator_create(shared_context(), map, 0.0, &ev));
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_band(ev, origin, 1.0, count, 2.0, 8.0, 0.5, nullptr, nullptr, p0.data(), n),
      POTMAP_ERROR_DIMENSION_MISMATCH);
  POTMAP_ASSERT_OK(potmap_evaluator_destroy(ev));
  POTMAP_ASSERT_OK(potmap_map_destroy(map));
}
