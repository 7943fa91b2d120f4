// The C API on the host's own OpenCL objects: its context and queue, its cl_mem buffers, its
// events; and the refusals of objects that belong elsewhere.
#include <cmath>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "capi_test_support.hpp"

using namespace capi_test;

namespace {

struct Fixture {
  HostCl cl;
  Arrays arrays;
  potmap_context* ctx = nullptr;
  potmap_map* map = nullptr;
  potmap_evaluator* ev = nullptr;

  explicit Fixture(int dim = 2, std::size_t kernels = 150) : arrays(random_map(dim, kernels, 7)) {
    EXPECT_EQ(potmap_context_create_from_queue(cl.queue, &ctx), POTMAP_SUCCESS)
        << potmap_last_error();
    map = make_map(arrays);
    EXPECT_EQ(potmap_evaluator_create(ctx, map, 0, &ev), POTMAP_SUCCESS) << potmap_last_error();
  }
  ~Fixture() {
    potmap_evaluator_destroy(ev);
    potmap_map_destroy(map);
    potmap_context_destroy(ctx);
  }
};

// Points as the device entry point takes them: floats relative to an origin.
std::vector<float> relative(const std::vector<double>& pts, const double* origin, int dim) {
  std::vector<float> out(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) out[i] = float(pts[i] - origin[i % dim]);
  return out;
}

}  // namespace

TEST(CApiDevice, ContextFromHostQueueSharesIt) {
  Fixture f;
  cl_context cx = nullptr;
  cl_command_queue q = nullptr;
  cl_device_id dev = nullptr;
  POTMAP_ASSERT_OK(potmap_context_cl(f.ctx, &cx, &dev, &q));
  EXPECT_EQ(q, f.cl.queue);
  EXPECT_EQ(cx, f.cl.context);
  EXPECT_EQ(dev, f.cl.device);
}

TEST(CApiDevice, ContextFromHostContextAndDevice) {
  HostCl cl;
  const cl_uint before = reference_count(cl.context);
  potmap_context* ctx = nullptr;
  POTMAP_EXPECT_FAIL(potmap_context_create_from_cl(nullptr, cl.device, &ctx),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(potmap_context_create_from_cl(cl.context, nullptr, &ctx),
                     POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_ASSERT_OK(potmap_context_create_from_cl(cl.context, cl.device, &ctx));
  cl_context cx = nullptr;
  cl_command_queue q = nullptr;
  POTMAP_ASSERT_OK(potmap_context_cl(ctx, &cx, nullptr, &q));
  EXPECT_EQ(cx, cl.context);
  EXPECT_NE(q, cl.queue) << "potmap makes its own queue on the host's context";
  EXPECT_GT(reference_count(cl.context), before);
  POTMAP_ASSERT_OK(potmap_context_destroy(ctx));
  EXPECT_EQ(reference_count(cl.context), before) << "everything potmap held is released";
}

TEST(CApiDevice, DeviceOutsideTheContextIsRefused) {
  // A sub-device is a device the host context does not contain (PoCL supports partitioning;
  // drivers without it have no second device to try here).
  HostCl cl;
  cl_uint max_sub = 0;
  clGetDeviceInfo(cl.device, CL_DEVICE_PARTITION_MAX_SUB_DEVICES, sizeof max_sub, &max_sub,
                  nullptr);
  const cl_device_partition_property props[] = {CL_DEVICE_PARTITION_EQUALLY, 1, 0};
  cl_uint nsub = 0;
  if (max_sub < 2 || clCreateSubDevices(cl.device, props, 0, nullptr, &nsub) != CL_SUCCESS ||
      nsub == 0)
    GTEST_SKIP() << "the device cannot be partitioned: no device outside the context to try";
  std::vector<cl_device_id> subs(nsub);
  ASSERT_EQ(clCreateSubDevices(cl.device, props, nsub, subs.data(), nullptr), CL_SUCCESS);
  potmap_context* ctx = nullptr;
  POTMAP_EXPECT_FAIL(potmap_context_create_from_cl(cl.context, subs[0], &ctx),
                     POTMAP_ERROR_CONTEXT_MISMATCH);
  EXPECT_EQ(ctx, nullptr);
  for (cl_device_id d : subs) clReleaseDevice(d);
}

TEST(CApiDevice, EvaluateOnHostBuffersWaitsOnReturnedEvent) {
  for (int dim : {2, 3}) {
    Fixture f(dim);
    const std::size_t n = 300;
    const std::vector<double> pts = random_points(dim, n, 60 + dim);
    const double origin[3] = {10.0, 10.0, 10.0};
    const std::vector<float> rel = relative(pts, origin, dim);
    cl_mem d_pts = f.cl.buffer(rel.size() * sizeof(float), rel.data());
    cl_mem d_prob = f.cl.buffer(n * sizeof(float)), d_var = f.cl.buffer(n * sizeof(float));

    // The launch must wait for the host's own event: a user event holds it back.
    cl_int err = CL_SUCCESS;
    cl_event gate = clCreateUserEvent(f.cl.context, &err);
    ASSERT_EQ(err, CL_SUCCESS);
    cl_event done = nullptr;
    POTMAP_ASSERT_OK(potmap_evaluate_device(f.ev, d_pts, n, dim, origin, nullptr, d_var, d_prob, 1,
                                            &gate, &done));
    ASSERT_NE(done, nullptr);
    cl_int state = CL_COMPLETE;
    clGetEventInfo(done, CL_EVENT_COMMAND_EXECUTION_STATUS, sizeof state, &state, nullptr);
    EXPECT_NE(state, CL_COMPLETE) << "ran before the wait list was complete";
    ASSERT_EQ(clSetUserEventStatus(gate, CL_COMPLETE), CL_SUCCESS);
    ASSERT_EQ(clWaitForEvents(1, &done), CL_SUCCESS);
    // (Its reference count says little: PoCL keeps references of its own to recent events.
    // That potmap hands out exactly one is checked by the soak test: no event outlives it.)
    clReleaseEvent(done);
    clReleaseEvent(gate);

    const Values want = reference(f.arrays, pts);
    const std::vector<float> prob = f.cl.read(d_prob, n), var = f.cl.read(d_var, n);
    std::vector<float> host_prob(n);
    POTMAP_ASSERT_OK(
        potmap_evaluate(f.ev, pts.data(), n, dim, nullptr, nullptr, host_prob.data(), n));
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_NEAR(prob[i], want.prob[i], 1e-5) << dim << "D point " << i;
      ASSERT_NEAR(prob[i], host_prob[i], 1e-5) << dim << "D point " << i;
      ASSERT_NEAR(var[i], want.var[i], 1e-4 * (1 + want.var[i])) << i;
    }
    // The host's buffers are as the host left them: potmap kept no reference.
    EXPECT_EQ(reference_count(d_pts), 1u);
    EXPECT_EQ(reference_count(d_prob), 1u);
    for (cl_mem m : {d_pts, d_prob, d_var}) clReleaseMemObject(m);
  }
}

TEST(CApiDevice, NoPointsStillGivesAnEvent) {
  Fixture f;
  cl_mem d_prob = f.cl.buffer(4);
  cl_event done = nullptr;
  POTMAP_ASSERT_OK(potmap_evaluate_device(f.ev, nullptr, 0, 2, nullptr, nullptr, nullptr, d_prob, 0,
                                          nullptr, &done));
  ASSERT_NE(done, nullptr);
  EXPECT_EQ(clWaitForEvents(1, &done), CL_SUCCESS);
  clReleaseEvent(done);
  // Without an event out-pointer the work still runs; the queue is finished by the host.
  POTMAP_ASSERT_OK(potmap_evaluate_device(f.ev, nullptr, 0, 2, nullptr, nullptr, nullptr, d_prob, 0,
                                          nullptr, nullptr));
  EXPECT_EQ(clFinish(f.cl.queue), CL_SUCCESS);
  clReleaseMemObject(d_prob);
}

TEST(CApiDevice, RefusesBadBuffersAndEvents) {
  Fixture f;
  const std::size_t n = 64;
  const double origin[2] = {0, 0};
  cl_mem pts = f.cl.buffer(n * 2 * sizeof(float)), prob = f.cl.buffer(n * sizeof(float));
  cl_mem short_pts = f.cl.buffer(n * 2 * sizeof(float) - 4);
  cl_mem short_out = f.cl.buffer(n * sizeof(float) - 4);
  cl_event ev = nullptr;

  POTMAP_EXPECT_FAIL(potmap_evaluate_device(f.ev, short_pts, n, 2, origin, nullptr, nullptr, prob,
                                            0, nullptr, &ev),
                     POTMAP_ERROR_BUFFER_TOO_SMALL);
  EXPECT_TRUE(std::string(potmap_last_error()).find("points") != std::string::npos);
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_device(f.ev, pts, n, 2, origin, short_out, nullptr, prob, 0, nullptr, &ev),
      POTMAP_ERROR_BUFFER_TOO_SMALL);
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_device(f.ev, pts, n, 3, origin, nullptr, nullptr, prob, 0, nullptr, &ev),
      POTMAP_ERROR_DIMENSION_MISMATCH);
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_device(f.ev, pts, n, 2, origin, nullptr, nullptr, nullptr, 0, nullptr, &ev),
      POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_device(f.ev, nullptr, n, 2, origin, nullptr, nullptr, prob, 0, nullptr, &ev),
      POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_device(f.ev, pts, n, 2, nullptr, nullptr, nullptr, prob, 0, nullptr, &ev),
      POTMAP_ERROR_NULL_ARGUMENT);
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_device(f.ev, pts, n, 2, origin, nullptr, nullptr, prob, 1, nullptr, &ev),
      POTMAP_ERROR_NULL_ARGUMENT);

  // Objects of another OpenCL context (another platform is refused the same way: the query
  // goes through the ICD loader to the owner's driver, which names a different context).
  HostCl other;
  cl_mem foreign = other.buffer(n * 2 * sizeof(float));
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_device(f.ev, foreign, n, 2, origin, nullptr, nullptr, prob, 0, nullptr, &ev),
      POTMAP_ERROR_CONTEXT_MISMATCH);
  POTMAP_EXPECT_FAIL(
      potmap_evaluate_device(f.ev, pts, n, 2, origin, nullptr, foreign, prob, 0, nullptr, &ev),
      POTMAP_ERROR_CONTEXT_MISMATCH);
  cl_int err = CL_SUCCESS;
  cl_event foreign_event = clCreateUserEvent(other.context, &err);
  ASSERT_EQ(err, CL_SUCCESS);
  POTMAP_EXPECT_FAIL(potmap_evaluate_device(f.ev, pts, n, 2, origin, nullptr, nullptr, prob, 1,
                                            &foreign_event, &ev),
                     POTMAP_ERROR_CONTEXT_MISMATCH);
  EXPECT_EQ(ev, nullptr) << "no event handed out on failure";
  clSetUserEventStatus(foreign_event, CL_COMPLETE);
  clReleaseEvent(foreign_event);
  // No failed call kept a reference to what it was given.
  EXPECT_EQ(reference_count(pts), 1u);
  EXPECT_EQ(reference_count(foreign), 1u);
  for (cl_mem m : {pts, prob, short_pts, short_out, foreign}) clReleaseMemObject(m);
}

TEST(CApiDevice, EvaluatorsOnOneContextRunOnSeveralThreads) {
  HostCl cl;
  potmap_context* ctx = nullptr;
  POTMAP_ASSERT_OK(potmap_context_create_from_queue(cl.queue, &ctx));
  const Arrays a = random_map(2, 120, 70), b = random_map(2, 80, 71);
  const std::vector<double> pts = random_points(2, 400, 72);
  const Values want_a = reference(a, pts), want_b = reference(b, pts);
  auto work = [&](const Arrays& arr, const Values& want, int* bad) {
    potmap_map* map = make_map(arr);
    potmap_evaluator* ev = nullptr;
    if (potmap_evaluator_create(ctx, map, 0, &ev) != POTMAP_SUCCESS) {
      *bad = -1;
      return;
    }
    std::vector<float> prob(400);
    for (int round = 0; round < 20; ++round) {
      if (potmap_evaluate(ev, pts.data(), 400, 2, nullptr, nullptr, prob.data(), 400) != 0) {
        *bad = -2;
        break;
      }
      for (std::size_t i = 0; i < 400; ++i) *bad += std::fabs(prob[i] - want.prob[i]) > 1e-5;
    }
    potmap_evaluator_destroy(ev);
    potmap_map_destroy(map);
  };
  int bad_a = 0, bad_b = 0;
  std::thread ta(work, std::cref(a), std::cref(want_a), &bad_a);
  std::thread tb(work, std::cref(b), std::cref(want_b), &bad_b);
  ta.join();
  tb.join();
  EXPECT_EQ(bad_a, 0);
  EXPECT_EQ(bad_b, 0);
  POTMAP_ASSERT_OK(potmap_context_destroy(ctx));
}
