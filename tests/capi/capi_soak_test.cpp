// Soak: thousands of create/evaluate/destroy cycles through the C API must leave no OpenCL
// object and no memory behind. Live OpenCL objects are counted through the host context's
// reference count, which the driver raises for each queue, buffer, program and event made in it
// (PoCL does; a driver that does not still must bring it back to where it was).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "capi_test_support.hpp"

using namespace capi_test;

namespace {

// One cycle: a fresh map, an evaluator, a device-buffer evaluation (and, every `host_every`
// cycles, a host-array one: each costs a few blocking round trips to the device), release.
void cycle(int index, potmap_context* ctx, const Arrays& a, const std::vector<double>& pts,
           cl_mem d_pts, cl_mem d_prob, int* failures) {
  constexpr int host_every = 20;
  const std::size_t n = pts.size() / 2;
  potmap_map* map = nullptr;
  potmap_evaluator* ev = nullptr;
  std::vector<float> prob(n);
  const double origin[2] = {0, 0};
  cl_event done = nullptr;
  *failures += potmap_map_create(2, a.size(), a.position.data(), a.gamma.data(), a.w_mean.data(),
                                 a.w_var.data(), &map) != POTMAP_SUCCESS;
  *failures += potmap_evaluator_create(ctx, map, 0, &ev) != POTMAP_SUCCESS;
  if (index % host_every == 0)
    *failures += potmap_evaluate(ev, pts.data(), n, 2, nullptr, nullptr, prob.data(), n) != 0;
  *failures += potmap_evaluate_device(ev, d_pts, n, 2, origin, nullptr, nullptr, d_prob, 0, nullptr,
                                      &done) != 0;
  if (done) {
    clWaitForEvents(1, &done);
    clReleaseEvent(done);
  }
  // An error path in every cycle too: failures must not leak either.
  float one = 0;
  *failures += potmap_evaluate(ev, pts.data(), n, 2, nullptr, nullptr, &one, 1) !=
               POTMAP_ERROR_BUFFER_TOO_SMALL;
  *failures += potmap_evaluator_destroy(ev) != POTMAP_SUCCESS;
  *failures += potmap_map_destroy(map) != POTMAP_SUCCESS;
}

}  // namespace

TEST(CApiSoak, CyclesLeaveNoObjectsOrMemoryBehind) {
  // POTMAP_SOAK_CYCLES scales it (e.g. longer by hand); 2000 by default, a few s on PoCL.
  const char* env = std::getenv("POTMAP_SOAK_CYCLES");
  const int cycles = env ? std::max(500, std::atoi(env)) : 2000;
  // Contexts are made and destroyed too, but fewer: each loads its programs (~0.3 s on PoCL).
  const int per_context = 500;

  HostCl cl;
  const Arrays a = random_map(2, 1000, 80);  // 40 kB of map: a leaked copy per cycle shows
  std::vector<double> pts = random_points(2, 64, 81);
  std::vector<float> rel(pts.begin(), pts.end());
  cl_mem d_pts = cl.buffer(rel.size() * sizeof(float), rel.data());
  cl_mem d_prob = cl.buffer(64 * sizeof(float));
  int failures = 0;

  auto run = [&](int count) {
    for (int done = 0; done < count; done += per_context) {
      potmap_context* ctx = nullptr;
      if (potmap_context_create_from_queue(cl.queue, &ctx) != POTMAP_SUCCESS) {
        ++failures;
        return;
      }
      for (int i = 0; i < per_context && done + i < count; ++i)
        cycle(done + i, ctx, a, pts, d_pts, d_prob, &failures);
      failures += potmap_context_destroy(ctx) != POTMAP_SUCCESS;
    }
  };

  // Warm-up: first-use allocations (driver pools, program binaries, allocator arenas).
  run(per_context);
  ASSERT_EQ(failures, 0) << potmap_last_error();
  const cl_uint context_refs = reference_count(cl.context);
  const cl_uint queue_refs = reference_count(cl.queue);
  const std::size_t rss_before = resident_bytes();

  run(cycles);
  ASSERT_EQ(failures, 0) << potmap_last_error();
  clFinish(cl.queue);
  const std::size_t rss_after = resident_bytes();

  EXPECT_EQ(reference_count(cl.context), context_refs) << "live OpenCL objects grew";
  EXPECT_EQ(reference_count(cl.queue), queue_refs);
  EXPECT_EQ(reference_count(d_pts), 1u);
  EXPECT_EQ(reference_count(d_prob), 1u);
  // A leaked map copy (40 kB), evaluator (its device copy and lists) or event per cycle would
  // add at least 80 MB over 2000 cycles; allocator noise stays far below the bound.
  const double growth_mb = (double(rss_after) - double(rss_before)) / (1 << 20);
  EXPECT_LT(growth_mb, 16.0) << "resident memory grew by " << growth_mb << " MB over " << cycles
                             << " cycles";
  std::printf("soak: %d cycles, resident memory %+.2f MB, context references %u -> %u\n", cycles,
              growth_mb, context_refs, reference_count(cl.context));
  clReleaseMemObject(d_pts);
  clReleaseMemObject(d_prob);
}
