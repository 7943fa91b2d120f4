#include <gtest/gtest.h>

#include <chrono>

#include <filesystem>

#include "potmap/error.hpp"
#include "potmap/runtime/context.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace potmap;

TEST(Context, PicksADeviceAndNamesIt) {
  Context& ctx = test::context();
  EXPECT_FALSE(ctx.info().name.empty());
  EXPECT_FALSE(ctx.info().platform.empty());
  EXPECT_NE(ctx.info().summary().find(ctx.info().name), std::string::npos);
}

TEST(Context, UnknownDeviceNameListsDevices) {
  ContextOptions o;
  o.device = "no-such-device-xyz";
  try {
    Context c(o);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no-such-device-xyz"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find(list_devices().at(0).name), std::string::npos);
  }
}

// A device is picked by its platform's vendor too ("pocl" for Debian's PoCL, whose platform is
// named "Portable Computing Language").
TEST(Context, PicksADeviceByItsPlatformsVendor) {
  const DeviceInfo first = list_devices().at(0);
  ASSERT_FALSE(first.platform_vendor.empty());
  ContextOptions o;
  o.device = first.platform_vendor;
  EXPECT_EQ(Context(o).info().platform_vendor, first.platform_vendor);
  if (first.platform_vendor.find("pocl") != std::string::npos) {
    o.device = "PoCL";
    EXPECT_EQ(Context(o).info().name, first.name);
  }
}

TEST(Context, EveryEmbeddedKernelCompilesOnItsOwn) {
  const auto names = embedded_kernel_names();
  ASSERT_FALSE(names.empty());
  for (const std::string& n : names) {
    SCOPED_TRACE(n);
    EXPECT_NO_THROW(test::context().program(n));
  }
}

TEST(Context, EmbeddedKernelsCarryTheirSharedParts) {
  // `#include "../common/..."` lines are expanded when the kernels are embedded.
  for (const std::string& n : embedded_kernel_names()) {
    SCOPED_TRACE(n);
    EXPECT_EQ(embedded_kernel_source(n).find("#include"), std::string::npos);
  }
  for (const char* n : {"ot/sinkhorn", "ot/sinkhorn_stab"})
    EXPECT_NE(embedded_kernel_source(n).find("} SinkhornLaunchInts;"), std::string::npos) << n;
}

// A kernel the compiler warns about builds quietly; the warnings reach stderr only when the
// kernels are dumped (POTMAP_DUMP_KERNELS, ContextOptions::dump_kernels).
TEST(Context, BuildWarningsOnlyWhenDumping) {
  for (const bool dump : {false, true}) {
    // A source of its own every run, so that PoCL's own kernel cache cannot skip the compiler.
    const std::string src =
        "// " + std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()) +
        "\n__kernel void g(__global float* x) { __global int* q = x; q[get_global_id(0)] = 1; }";
    ContextOptions o;
    o.disk_cache = false;
    o.dump_kernels = dump;
    Context ctx(o);
    testing::internal::CaptureStderr();
    ctx.program_from_source("warns", src);
    const std::string err = testing::internal::GetCapturedStderr();
    if (dump) {
      EXPECT_NE(err.find("build log of 'warns'"), std::string::npos) << err;
      EXPECT_NE(err.find("incompatible pointer types"), std::string::npos) << err;
    } else {
      EXPECT_EQ(err, "");
    }
  }
}

TEST(Context, ProgramsAreCachedInMemory) {
  ContextOptions o;
  o.disk_cache = false;  // ctest sets POTMAP_CACHE_DIR; this test counts compiler builds
  Context ctx(o);
  const std::string src = "__kernel void f(__global float* x) { x[get_global_id(0)] = 2.0f; }";
  ctx.program_from_source("f", src);
  ctx.program_from_source("f", src);
  EXPECT_EQ(ctx.builds_from_source(), 1u);
  ctx.program_from_source("f", src, "-DX=1");
  EXPECT_EQ(ctx.builds_from_source(), 2u);
}

// A lease given back is lent again (no new cl_kernel, no program lookup); leases alive at once
// never share a kernel, whose argument state is its borrower's.
TEST(Context, LentKernelsComeBackAndAreNeverShared) {
  Context& ctx = test::context();
  const std::string defines = "-DDIM=2";
  cl_kernel first = nullptr;
  {
    KernelLease a = ctx.lend_kernel("learn/bhm_update", "bhm_accumulate", defines);
    first = a->get();
    KernelLease b = ctx.lend_kernel("learn/bhm_update", "bhm_accumulate", defines);
    EXPECT_NE(b->get(), first);
    KernelLease moved = std::move(b);
    EXPECT_NE(moved->get(), nullptr);
  }
  std::vector<KernelLease> again;
  again.push_back(ctx.lend_kernel("learn/bhm_update", "bhm_accumulate", defines));
  again.push_back(ctx.lend_kernel("learn/bhm_update", "bhm_accumulate", defines));
  EXPECT_TRUE(again[0]->get() == first || again[1]->get() == first);
  EXPECT_NE(again[0]->get(), again[1]->get());
  EXPECT_EQ((*again[0]).name(), "bhm_accumulate");
}

TEST(Context, BuildFailureCarriesTheLogAndErrorName) {
  const std::string src = "__kernel void broken(__global float* x) { x[0] = undefined_name; }";
  try {
    test::context().program_from_source("broken", src);
    FAIL() << "expected BuildError";
  } catch (const BuildError& e) {
    EXPECT_EQ(e.name(), "CL_BUILD_PROGRAM_FAILURE");
    EXPECT_NE(e.log().find("undefined_name"), std::string::npos) << e.log();
    EXPECT_NE(std::string(e.what()).find("broken"), std::string::npos);
  }
}

TEST(Context, UnknownKernelNameThrowsOpenCLError) {
  try {
    test::context().kernel("map/evaluate", "no_such_kernel");
    FAIL() << "expected OpenCLError";
  } catch (const OpenCLError& e) {
    EXPECT_EQ(e.name(), "CL_INVALID_KERNEL_NAME");
    EXPECT_NE(std::string(e.what()).find("no_such_kernel"), std::string::npos);
  }
}

TEST(Context, DiskCacheIsUsedAndSurvivesCorruption) {
  const std::string dir = test::temp_dir("binary-cache");
  const std::string src = "__kernel void g(__global int* x) { x[get_global_id(0)] = 7; }";
  {
    ContextOptions o;
    o.binary_cache_dir = dir;
    Context ctx(o);
    ctx.program_from_source("g", src);
    EXPECT_EQ(ctx.builds_from_source(), 1u);
  }
  {
    ContextOptions o;
    o.binary_cache_dir = dir;
    Context ctx(o);
    ctx.program_from_source("g", src);
    EXPECT_EQ(ctx.builds_from_source(), 0u);
    EXPECT_EQ(ctx.disk_cache_hits(), 1u);
  }
  // Corrupt every cached binary: potmap must rebuild from source, not fail.
  for (const auto& e : fs::directory_iterator(dir)) {
    std::FILE* f = std::fopen(e.path().c_str(), "r+b");
    ASSERT_NE(f, nullptr);
    std::fseek(f, -64, SEEK_END);
    const char junk[64] = {1, 2, 3, 4, 5, 6, 7, 8};
    std::fwrite(junk, 1, sizeof junk, f);
    std::fclose(f);
  }
  {
    ContextOptions o;
    o.binary_cache_dir = dir;
    Context ctx(o);
    EXPECT_NO_THROW(ctx.program_from_source("g", src));
  }
}

TEST(Context, UnwritableCacheFolderIsIgnored) {
  ContextOptions o;
  o.binary_cache_dir = "/proc/potmap-cannot-write-here";
  Context ctx(o);
  EXPECT_NO_THROW(ctx.program_from_source(
      "h", "__kernel void h(__global int* x) { x[get_global_id(0)] = 1; }"));
  EXPECT_EQ(ctx.builds_from_source(), 1u);
}

TEST(Context, WrapsAHostQueue) {
  Context& base = test::context();
  Context wrapped(base.queue().get());
  EXPECT_EQ(wrapped.info().name, base.info().name);
  EXPECT_EQ(wrapped.queue().get(), base.queue().get());
}

TEST(Context, DumpKernelsPrintsTheSource) {
  ContextOptions o;
  o.dump_kernels = true;
  Context ctx(o);
  testing::internal::CaptureStderr();
  ctx.program_from_source("dumped",
                          "__kernel void dumped_marker_kernel(__global int* x) { x[0] = 3; }");
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("dumped_marker_kernel"), std::string::npos) << err;
}

TEST(Context, DeviceChosenByEnvironment) {
  const std::string first = list_devices().at(0).name;
  const char* old = std::getenv("POTMAP_DEVICE");
  const std::string saved = old ? old : "";
  ::setenv("POTMAP_DEVICE", first.substr(0, 6).c_str(), 1);
  EXPECT_EQ(Context().info().name.substr(0, 6), first.substr(0, 6));
  ::setenv("POTMAP_DEVICE", "definitely-not-a-device", 1);
  EXPECT_THROW(Context(), Error);
  // An explicit option wins over the environment.
  ContextOptions o;
  o.device = first.substr(0, 6);
  EXPECT_NO_THROW(Context{o});
  if (old)
    ::setenv("POTMAP_DEVICE", saved.c_str(), 1);
  else
    ::unsetenv("POTMAP_DEVICE");
}
