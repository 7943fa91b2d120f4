// C API: evaluators, on host arrays and on the host's own device buffers.
#include <boost/compute/buffer.hpp>
#include <boost/compute/event.hpp>
#include <boost/compute/utility/wait_list.hpp>

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "capi_handles.hpp"
#include "potmap/map/height_band.hpp"
#include "runtime/cl_check.hpp"

namespace bc = boost::compute;

namespace potmap::capi {
namespace {

void check_dim(const potmap_evaluator& e, int dim) {
  if (dim != e.dim)
    fail(POTMAP_ERROR_DIMENSION_MISMATCH,
         "points are " + std::to_string(dim) + "D but the map is " + std::to_string(e.dim) + "D");
}

// Sizes past this would overflow the byte counts below.
void check_count(std::size_t n, const char* what) {
  if (n > std::numeric_limits<std::size_t>::max() / 64)
    fail(POTMAP_ERROR_INVALID_ARGUMENT,
         std::string(what) + " " + std::to_string(n) + " is too large");
}

void check_outputs(const float* mean, const float* var, const float* prob, std::size_t capacity,
                   std::size_t needed) {
  if (!mean && !var && !prob) fail(POTMAP_ERROR_NULL_ARGUMENT, "mean, var and prob are all null");
  if (capacity < needed)
    fail(POTMAP_ERROR_BUFFER_TOO_SMALL, "output capacity is " + std::to_string(capacity) +
                                            " floats, the call writes " + std::to_string(needed));
}

// A host buffer must belong to the evaluator's context and hold `bytes`; OpenCL reports an
// object of another platform through the same query (the ICD loader dispatches on it).
void check_mem(cl_mem m, cl_context cx, std::size_t bytes, const char* what) {
  cl_context owner = nullptr;
  cl_int s = clGetMemObjectInfo(m, CL_MEM_CONTEXT, sizeof owner, &owner, nullptr);
  if (s != CL_SUCCESS)
    fail(s, std::string("clGetMemObjectInfo(CL_MEM_CONTEXT) on ") + what +
                " failed: " + opencl_error_name(s));
  if (owner != cx)
    fail(POTMAP_ERROR_CONTEXT_MISMATCH,
         std::string(what) + " belongs to another OpenCL context than the evaluator's");
  std::size_t size = 0;
  s = clGetMemObjectInfo(m, CL_MEM_SIZE, sizeof size, &size, nullptr);
  if (s != CL_SUCCESS)
    fail(s, std::string("clGetMemObjectInfo(CL_MEM_SIZE) on ") + what +
                " failed: " + opencl_error_name(s));
  if (size < bytes)
    fail(POTMAP_ERROR_BUFFER_TOO_SMALL, std::string(what) + " holds " + std::to_string(size) +
                                            " bytes, the call needs " + std::to_string(bytes));
}

void check_event(cl_event ev, cl_context cx, cl_uint i) {
  if (!ev) fail(POTMAP_ERROR_NULL_ARGUMENT, "wait_events[" + std::to_string(i) + "] is null");
  cl_context owner = nullptr;
  cl_int s = clGetEventInfo(ev, CL_EVENT_CONTEXT, sizeof owner, &owner, nullptr);
  if (s != CL_SUCCESS)
    fail(s, "clGetEventInfo(CL_EVENT_CONTEXT) on wait_events[" + std::to_string(i) +
                "] failed: " + opencl_error_name(s));
  if (owner != cx)
    fail(POTMAP_ERROR_CONTEXT_MISMATCH,
         "wait_events[" + std::to_string(i) + "] belongs to another OpenCL context");
}

}  // namespace
}  // namespace potmap::capi

using namespace potmap::capi;

extern "C" {

potmap_status potmap_evaluator_create(potmap_context* context, const potmap_map* map, double tau,
                                      potmap_evaluator** out) {
  return guard("potmap_evaluator_create", POTMAP_ERROR_INTERNAL, [&] {
    potmap_context& c = checked(context);
    const potmap_map& m = checked(map);
    require(out, "out");
    if (!(tau >= 0) || !std::isfinite(tau))
      fail(POTMAP_ERROR_INVALID_ARGUMENT,
           "tau must be finite and >= 0 (0: default), got " + std::to_string(tau));
    potmap::EvalOptions options;
    if (tau > 0) options.tau = tau;
    auto h = std::make_unique<potmap_evaluator>();
    h->ctx = c.ctx;
    h->eval = std::make_unique<potmap::MapEvaluator>(*c.ctx, m.map, options);
    h->dim = m.map.dim;
    h->band_step = potmap::default_band_step(m.map);
    *out = h.release();
  });
}

potmap_status potmap_evaluator_destroy(potmap_evaluator* evaluator) {
  return destroy(evaluator, kEvaluatorTag, "potmap_evaluator_destroy");
}

potmap_status potmap_evaluate(potmap_evaluator* evaluator, const double* points, size_t n, int dim,
                              float* mean, float* var, float* prob, size_t capacity) {
  return guard("potmap_evaluate", POTMAP_ERROR_INTERNAL, [&] {
    potmap_evaluator& e = checked(evaluator);
    check_dim(e, dim);
    check_outputs(mean, var, prob, capacity, n);
    if (n == 0) return;
    require(points, "points");
    check_count(n, "n");
    e.eval->evaluate(points, n, mean, var, prob);
  });
}

potmap_status potmap_evaluate_grid(potmap_evaluator* evaluator, int dim, const double origin[3],
                                   double resolution, const size_t count[3], float* mean,
                                   float* var, float* prob, size_t capacity) {
  return guard("potmap_evaluate_grid", POTMAP_ERROR_INTERNAL, [&] {
    potmap_evaluator& e = checked(evaluator);
    require(origin, "origin");
    require(count, "count");
    check_dim(e, dim);
    potmap::GridSpec grid;
    grid.dim = dim;
    grid.resolution = resolution;
    for (int d = 0; d < 3; ++d) {
      grid.origin[d] = origin[d];
      grid.count[d] = (d < dim) ? count[d] : 1;
      check_count(grid.count[d], "count");
    }
    // Overflow-safe product: each factor is below 2^58, checked one multiplication at a time.
    std::size_t cells = 1;
    for (int d = 0; d < dim; ++d) {
      if (grid.count[d] != 0 &&
          cells > std::numeric_limits<std::size_t>::max() / 64 / grid.count[d])
        fail(POTMAP_ERROR_INVALID_ARGUMENT, "the grid has too many cells");
      cells *= grid.count[d];
    }
    check_outputs(mean, var, prob, capacity, cells);
    e.eval->evaluate_grid(grid, mean, var, prob);
  });
}

potmap_status potmap_evaluate_band(potmap_evaluator* evaluator, const double origin[2],
                                   double resolution, const size_t count[2], double z_lo,
                                   double z_hi, double step, float* mean, float* var, float* prob,
                                   size_t capacity) {
  return guard("potmap_evaluate_band", POTMAP_ERROR_INTERNAL, [&] {
    potmap_evaluator& e = checked(evaluator);
    require(origin, "origin");
    require(count, "count");
    if (e.dim != 3)
      fail(POTMAP_ERROR_DIMENSION_MISMATCH,
           "a height band needs a 3D map; the map is " + std::to_string(e.dim) + "D");
    if (!(step >= 0) || !std::isfinite(step))
      fail(POTMAP_ERROR_INVALID_ARGUMENT,
           "step must be finite and >= 0 (0: the map's default), got " + std::to_string(step));
    potmap::GridSpec grid;
    grid.dim = 3;
    grid.resolution = resolution;
    for (int d = 0; d < 2; ++d) {
      grid.origin[d] = origin[d];
      grid.count[d] = count[d];
      check_count(count[d], "count");
    }
    if (count[1] != 0 && count[0] > std::numeric_limits<std::size_t>::max() / 64 / count[1])
      fail(POTMAP_ERROR_INVALID_ARGUMENT, "the grid has too many cells");
    check_outputs(mean, var, prob, capacity, count[0] * count[1]);
    const std::vector<double> levels =
        potmap::height_band_levels(z_lo, z_hi, step > 0 ? step : e.band_step);
    e.eval->evaluate_band_max(grid, levels, mean, var, prob);
  });
}

potmap_status potmap_evaluate_device(potmap_evaluator* evaluator, cl_mem points, size_t n, int dim,
                                     const double* origin, cl_mem mean, cl_mem var, cl_mem prob,
                                     cl_uint num_wait_events, const cl_event* wait_events,
                                     cl_event* event) {
  return guard("potmap_evaluate_device", POTMAP_ERROR_INTERNAL, [&] {
    potmap_evaluator& e = checked(evaluator);
    check_dim(e, dim);
    if (!mean && !var && !prob) fail(POTMAP_ERROR_NULL_ARGUMENT, "mean, var and prob are all null");
    if (num_wait_events > 0) require(wait_events, "wait_events");
    check_count(n, "n");
    const cl_context cx = e.ctx->context().get();
    if (n > 0) {
      require(points, "points");
      require(origin, "origin");
      check_mem(points, cx, n * dim * sizeof(float), "points");
    }
    if (mean) check_mem(mean, cx, n * sizeof(float), "mean");
    if (var) check_mem(var, cx, n * sizeof(float), "var");
    if (prob) check_mem(prob, cx, n * sizeof(float), "prob");
    bc::wait_list waits;
    for (cl_uint i = 0; i < num_wait_events; ++i) {
      check_event(wait_events[i], cx, i);
      waits.insert(bc::event(wait_events[i], /*retain=*/true));
    }

    bc::event done;
    if (n == 0) {
      // Still hand back a real event, so the caller's wait code needs no special case.
      cl_event marker = nullptr;
      potmap::detail::cl_check(
          clEnqueueMarkerWithWaitList(e.ctx->queue().get(), num_wait_events,
                                      num_wait_events ? wait_events : nullptr, &marker),
          "clEnqueueMarkerWithWaitList");
      done = bc::event(marker, /*retain=*/false);
    } else {
      const bc::buffer p(points, /*retain=*/true);
      bc::buffer m, v, q;
      if (mean) m = bc::buffer(mean, /*retain=*/true);
      if (var) v = bc::buffer(var, /*retain=*/true);
      if (prob) q = bc::buffer(prob, /*retain=*/true);
      done = e.eval->evaluate_device(p, n, origin, mean ? &m : nullptr, var ? &v : nullptr,
                                     prob ? &q : nullptr, waits);
    }
    if (event) {
      potmap::detail::cl_check(clRetainEvent(done.get()), "clRetainEvent");
      *event = done.get();
    }
  });
}

}  // extern "C"
