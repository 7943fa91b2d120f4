// C API: contexts on a chosen device or on the host's own OpenCL objects.
#include <algorithm>
#include <memory>
#include <utility>
#include <vector>

#include "capi_handles.hpp"
#include "runtime/cl_check.hpp"

namespace potmap::capi {
namespace {

potmap_context* wrap(std::shared_ptr<Context> ctx) {
  auto h = std::make_unique<potmap_context>();
  h->ctx = std::move(ctx);
  const DeviceInfo& d = h->ctx->info();
  h->info.platform = d.platform.c_str();
  h->info.platform_version = d.platform_version.c_str();
  h->info.name = d.name.c_str();
  h->info.driver_version = d.driver_version.c_str();
  h->info.is_gpu = d.is_gpu ? 1 : 0;
  h->info.is_cpu = d.is_cpu ? 1 : 0;
  h->info.has_fp64 = d.has_fp64 ? 1 : 0;
  h->info.compute_units = d.compute_units;
  h->info.max_work_group_size = d.max_work_group_size;
  h->info.global_mem_bytes = d.global_mem_bytes;
  h->info.max_alloc_bytes = d.max_alloc_bytes;
  return h.release();
}

}  // namespace
}  // namespace potmap::capi

using namespace potmap::capi;

extern "C" {

potmap_status potmap_context_create(const char* device, potmap_context** out) {
  return guard("potmap_context_create", POTMAP_ERROR_NO_DEVICE, [&] {
    require(out, "out");
    potmap::ContextOptions options;
    if (device) options.device = device;
    *out = wrap(std::make_shared<potmap::Context>(options));
  });
}

potmap_status potmap_context_create_from_cl(cl_context context, cl_device_id device,
                                            potmap_context** out) {
  return guard("potmap_context_create_from_cl", POTMAP_ERROR_INTERNAL, [&] {
    require(context, "context");
    require(device, "device");
    require(out, "out");
    // Checked here too (the C++ constructor throws ArgumentError) for the distinct status.
    cl_uint n = 0;
    potmap::detail::cl_check(
        clGetContextInfo(context, CL_CONTEXT_NUM_DEVICES, sizeof n, &n, nullptr),
        "clGetContextInfo(CL_CONTEXT_NUM_DEVICES)");
    std::vector<cl_device_id> devices(n);
    potmap::detail::cl_check(clGetContextInfo(context, CL_CONTEXT_DEVICES, n * sizeof(cl_device_id),
                                              devices.data(), nullptr),
                             "clGetContextInfo(CL_CONTEXT_DEVICES)");
    if (std::find(devices.begin(), devices.end(), device) == devices.end())
      fail(POTMAP_ERROR_CONTEXT_MISMATCH, "the cl_device_id is not a device of the cl_context");
    *out = wrap(std::make_shared<potmap::Context>(context, device));
  });
}

potmap_status potmap_context_create_from_queue(cl_command_queue queue, potmap_context** out) {
  return guard("potmap_context_create_from_queue", POTMAP_ERROR_INTERNAL, [&] {
    require(queue, "queue");
    require(out, "out");
    *out = wrap(std::make_shared<potmap::Context>(queue));
  });
}

potmap_status potmap_context_destroy(potmap_context* context) {
  return destroy(context, kContextTag, "potmap_context_destroy");
}

potmap_status potmap_context_device_info(const potmap_context* context,
                                         const potmap_device_info** out) {
  return guard("potmap_context_device_info", POTMAP_ERROR_INTERNAL, [&] {
    const potmap_context& c = checked(context);
    require(out, "out");
    *out = &c.info;
  });
}

potmap_status potmap_context_cl(const potmap_context* context, cl_context* cl_ctx,
                                cl_device_id* device, cl_command_queue* queue) {
  return guard("potmap_context_cl", POTMAP_ERROR_INTERNAL, [&] {
    const potmap_context& c = checked(context);
    if (cl_ctx) *cl_ctx = c.ctx->context().get();
    if (device) *device = c.ctx->device().get();
    if (queue) *queue = c.ctx->queue().get();
  });
}

}  // extern "C"
