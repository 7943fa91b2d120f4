#pragma once
// Host-vector <-> device-buffer helpers shared by every device path (map evaluation, Sinkhorn,
// the learners). Every call goes through cl_call, so a failure is a potmap::OpenCLError naming
// the OpenCL call.

#include <algorithm>
#include <cstddef>
#include <vector>

#include <boost/compute/buffer.hpp>
#include <boost/compute/command_queue.hpp>
#include <boost/compute/context.hpp>

#include "potmap/runtime/context.hpp"
#include "runtime/cl_check.hpp"

namespace potmap::detail {

/// Zero-size buffers are invalid in OpenCL, and a few bytes more cost nothing: no buffer is
/// smaller than this.
constexpr std::size_t kMinBufferBytes = 64;

/// A new, uninitialised buffer of at least `bytes` bytes.
inline boost::compute::buffer device_buffer(boost::compute::context& cx, std::size_t bytes) {
  const std::size_t size = std::max(bytes, kMinBufferBytes);
  return cl_call("clCreateBuffer", [&] { return boost::compute::buffer(cx, size); });
}

/// Writes v to the start of b (blocking); nothing for an empty v.
template <class T>
void upload(boost::compute::command_queue& q, boost::compute::buffer& b, const std::vector<T>& v) {
  if (v.empty()) return;
  cl_call("clEnqueueWriteBuffer",
          [&] { q.enqueue_write_buffer(b, 0, v.size() * sizeof(T), v.data()); });
}
template <class T>
void upload(Context& ctx, boost::compute::buffer& b, const std::vector<T>& v) {
  upload(ctx.queue(), b, v);
}

/// A new buffer holding v.
template <class T>
boost::compute::buffer to_device(boost::compute::context& cx, boost::compute::command_queue& q,
                                 const std::vector<T>& v) {
  boost::compute::buffer b = device_buffer(cx, v.size() * sizeof(T));
  upload(q, b, v);
  return b;
}
template <class T>
boost::compute::buffer to_device(Context& ctx, const std::vector<T>& v) {
  return to_device(ctx.context(), ctx.queue(), v);
}

/// Reads `bytes` bytes from the start of b into dst (blocking); nothing for zero bytes.
inline void read_bytes(boost::compute::command_queue& q, const boost::compute::buffer& b,
                       std::size_t bytes, void* dst) {
  if (bytes == 0) return;
  cl_call("clEnqueueReadBuffer", [&] { q.enqueue_read_buffer(b, 0, bytes, dst); });
}

/// Reads v.size() elements from the start of b (blocking); nothing for an empty v.
template <class T>
void from_device(boost::compute::command_queue& q, const boost::compute::buffer& b,
                 std::vector<T>& v) {
  read_bytes(q, b, v.size() * sizeof(T), v.data());
}
template <class T>
void from_device(Context& ctx, const boost::compute::buffer& b, std::vector<T>& v) {
  from_device(ctx.queue(), b, v);
}

/// A device buffer that only grows, for paths that launch again and again with varying sizes.
struct GrowBuffer {
  boost::compute::buffer buf;
  std::size_t bytes = 0;
  /// The buffer, grown (by a quarter more than asked, so that slowly growing inputs do not
  /// reallocate every time) to hold at least `need` bytes; its contents are undefined.
  boost::compute::buffer& get(boost::compute::context& cx, std::size_t need) {
    need = std::max(need, kMinBufferBytes);
    if (need > bytes) {
      bytes = need + need / 4;
      buf = device_buffer(cx, bytes);
    }
    return buf;
  }
  /// The buffer, grown to hold v, with v written to its start.
  template <class T>
  boost::compute::buffer& put(boost::compute::context& cx, boost::compute::command_queue& q,
                              const std::vector<T>& v) {
    boost::compute::buffer& b = get(cx, v.size() * sizeof(T));
    upload(q, b, v);
    return b;
  }
};

/// n rounded up to a whole number of m (m > 0): the global size of a 1D launch.
inline std::size_t round_up(std::size_t n, std::size_t m) {
  return (n + m - 1) / m * m;
}

}  // namespace potmap::detail
