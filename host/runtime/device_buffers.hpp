#pragma once
// Host-vector <-> device-buffer helpers shared by the device paths. Every call goes through
// cl_call, so a failure is a potmap::OpenCLError naming the OpenCL call.

#include <algorithm>
#include <vector>

#include <boost/compute/buffer.hpp>

#include "potmap/runtime/context.hpp"
#include "runtime/cl_check.hpp"

namespace potmap::detail {

/// A new buffer holding v (zero-size buffers are invalid in OpenCL: at least one element).
template <class T>
boost::compute::buffer to_device(Context& ctx, const std::vector<T>& v) {
  const std::size_t bytes = std::max<std::size_t>(v.size(), 1) * sizeof(T);
  boost::compute::buffer b =
      cl_call("clCreateBuffer", [&] { return boost::compute::buffer(ctx.context(), bytes); });
  if (!v.empty())
    cl_call("clEnqueueWriteBuffer",
            [&] { ctx.queue().enqueue_write_buffer(b, 0, v.size() * sizeof(T), v.data()); });
  return b;
}

/// Writes v to the start of b (blocking); nothing for an empty v.
template <class T>
void upload(Context& ctx, boost::compute::buffer& b, const std::vector<T>& v) {
  if (v.empty()) return;
  cl_call("clEnqueueWriteBuffer",
          [&] { ctx.queue().enqueue_write_buffer(b, 0, v.size() * sizeof(T), v.data()); });
}

/// Reads v.size() elements from the start of b (blocking); nothing for an empty v.
template <class T>
void from_device(Context& ctx, boost::compute::buffer& b, std::vector<T>& v) {
  if (v.empty()) return;
  cl_call("clEnqueueReadBuffer",
          [&] { ctx.queue().enqueue_read_buffer(b, 0, v.size() * sizeof(T), v.data()); });
}

}  // namespace potmap::detail
