// A device buffer larger than the device allows (CL_DEVICE_MAX_MEM_ALLOC_SIZE), asked for
// through a public entry point: the error names the buffer and its size, the buffers made before
// it are released, and the Context works afterwards.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <string>
#include <thread>

#include "potmap/error.hpp"
#include "potmap/ot/sinkhorn.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

// Live OpenCL objects of the context (the driver counts each buffer, queue, program and event
// made in it), once the driver's own threads have let go of finished commands: the least of
// samples over 0.3 s.
cl_uint settled_objects(Context& ctx) {
  ctx.queue().finish();
  cl_uint best = UINT_MAX;
  for (int i = 0; i < 30; ++i) {
    cl_uint r = 0;
    clGetContextInfo(ctx.context().get(), CL_CONTEXT_REFERENCE_COUNT, sizeof r, &r, nullptr);
    best = std::min(best, r);
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return best;
}

SinkhornProblem line_problem(int n) {
  SinkhornProblem p;
  p.source.resize(n, 2);
  p.target.resize(n, 2);
  for (int i = 0; i < n; ++i) {
    p.source(i, 0) = 0.01 * i;
    p.source(i, 1) = 0;
    p.target(i, 0) = 0.01 * i + 0.003;
    p.target(i, 1) = 0.002 * (i % 3);
  }
  p.max_iterations = 50;
  return p;
}

}  // namespace

TEST(AllocationFault, AnImpossibleCouplingNamesItsBufferAndLeavesTheContextWorking) {
  Context& ctx = test::context();
  const std::uint64_t most = ctx.info().max_alloc_bytes;
  // A square problem whose dense coupling (n^2 floats) is past the device's largest buffer
  // while n^2 still fits the launch's int indices.
  const auto n = static_cast<long>(std::ceil(std::sqrt(double(most) / 4.0 * 1.05)));
  if (n * n > long(INT_MAX))
    GTEST_SKIP() << "the device allows buffers of " << most
                 << " bytes: no coupling the launch can index is larger";
  SinkhornOptions o;
  o.stabilised = false;  // the log domain: no kernel matrix, the coupling is the big buffer
  o.want_coupling = true;
  SinkhornBatch small;
  small.add(line_problem(20));
  SinkhornOptions so;
  so.stabilised = false;
  const std::vector<SinkhornResult> before = small.run(ctx, so);
  const cl_uint objects = settled_objects(ctx);

  SinkhornBatch huge;
  huge.add(line_problem(static_cast<int>(n)));
  const std::string bytes = std::to_string(n * n * 4) + " bytes";
  try {
    huge.run(ctx, o);
    FAIL() << "a coupling of " << bytes << " did not fail";
  } catch (const OpenCLError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("Sinkhorn: couplings"), std::string::npos) << what;
    EXPECT_NE(what.find(bytes), std::string::npos) << what;
    EXPECT_NE(what.find("at most " + std::to_string(most)), std::string::npos) << what;
  }

  EXPECT_EQ(settled_objects(ctx), objects) << "buffers of the failed launch were not released";
  const std::vector<SinkhornResult> after = small.run(ctx, so);
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(after[0].cost, before[0].cost);
  EXPECT_EQ(after[0].iterations, before[0].iterations);
}
