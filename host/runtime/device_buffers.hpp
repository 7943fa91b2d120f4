#pragma once
// Host-vector <-> device-buffer helpers shared by every device path (map evaluation, Sinkhorn,
// the learners). Every call goes through cl_call, so a failure is a potmap::OpenCLError naming
// the OpenCL call.

#include <algorithm>
#include <cstddef>
#include <string>
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

/// "<call>(<label>, <bytes> bytes)", plus the device's largest allocation when `bytes` is above
/// it: an out-of-memory error then says which of a routine's buffers did not fit, and why.
inline std::string buffer_call(const char* call, boost::compute::context& cx, const char* label,
                               std::size_t bytes) {
  std::string where = std::string(call) + "(" + label + ", " + std::to_string(bytes) + " bytes";
  try {
    const cl_ulong most = cx.get_device().get_info<cl_ulong>(CL_DEVICE_MAX_MEM_ALLOC_SIZE);
    if (bytes > most)
      where += "; the device allows at most " + std::to_string(most) +
               " bytes per buffer (CL_DEVICE_MAX_MEM_ALLOC_SIZE)";
  } catch (const boost::compute::opencl_error&) {
    // The limit is only a hint in a message that already names the failure.
  }
  return where + ")";
}

/// A new, uninitialised buffer of at least `bytes` bytes; `label` names it in the error should
/// the device refuse it (e.g. "evaluator: kernel positions"). A buffer made before a failure
/// is released by its destructor as the exception unwinds.
inline boost::compute::buffer device_buffer(boost::compute::context& cx, std::size_t bytes,
                                            const char* label) {
  const std::size_t size = std::max(bytes, kMinBufferBytes);
  try {
    return boost::compute::buffer(cx, size);
  } catch (const boost::compute::opencl_error& e) {
    throw OpenCLError(e.error_code(), buffer_call("clCreateBuffer", cx, label, size));
  }
}

/// Writes v to the start of b (blocking); nothing for an empty v. Drivers that allocate lazily
/// (PoCL) report an allocation failure here, so the error names the buffer too.
template <class T>
void upload(boost::compute::command_queue& q, boost::compute::buffer& b, const std::vector<T>& v,
            const char* label) {
  if (v.empty()) return;
  try {
    q.enqueue_write_buffer(b, 0, v.size() * sizeof(T), v.data());
  } catch (const boost::compute::opencl_error& e) {
    boost::compute::context cx = q.get_context();
    throw OpenCLError(e.error_code(),
                      buffer_call("clEnqueueWriteBuffer", cx, label, v.size() * sizeof(T)));
  }
}
template <class T>
void upload(Context& ctx, boost::compute::buffer& b, const std::vector<T>& v, const char* label) {
  upload(ctx.queue(), b, v, label);
}

/// A new buffer holding v (`label` as for device_buffer). The bytes are copied as the buffer is
/// made (CL_MEM_COPY_HOST_PTR), not by a command on the queue: a blocking write is a round trip
/// through the driver's worker threads, which on PoCL's CPU device took 0.5-1 ms per buffer
/// while other host threads kept the cores busy (docs/pot-scale.md).
template <class T>
boost::compute::buffer to_device(boost::compute::context& cx, boost::compute::command_queue& q,
                                 const std::vector<T>& v, const char* label) {
  (void)q;
  const std::size_t bytes = v.size() * sizeof(T);
  if (bytes == 0) return device_buffer(cx, 0, label);
  std::vector<unsigned char> padded;
  const void* src = v.data();
  if (bytes < kMinBufferBytes) {
    padded.assign(kMinBufferBytes, 0);
    std::copy_n(reinterpret_cast<const unsigned char*>(v.data()), bytes, padded.begin());
    src = padded.data();
  }
  const std::size_t size = std::max(bytes, kMinBufferBytes);
  try {
    return boost::compute::buffer(
        cx, size, boost::compute::buffer::read_write | boost::compute::buffer::copy_host_ptr,
        const_cast<void*>(src));
  } catch (const boost::compute::opencl_error& e) {
    throw OpenCLError(e.error_code(), buffer_call("clCreateBuffer", cx, label, size));
  }
}
template <class T>
boost::compute::buffer to_device(Context& ctx, const std::vector<T>& v, const char* label) {
  return to_device(ctx.context(), ctx.queue(), v, label);
}

/// Reads `bytes` bytes from the start of b into dst (blocking); nothing for zero bytes.
inline void read_bytes(boost::compute::command_queue& q, const boost::compute::buffer& b,
                       std::size_t bytes, void* dst) {
  if (bytes == 0) return;
  cl_call("clEnqueueReadBuffer", [&] { q.enqueue_read_buffer(b, 0, bytes, dst); });
}

/// Reads from a launch's buffers queued together and waited for once (`read` each, then
/// `wait`): every blocking read is a round trip through the driver's worker threads, which on
/// PoCL's CPU device costs 35-80 us on a quiet machine and far more while other host threads
/// hold the cores (docs/pot-scale.md), and a Sinkhorn launch reads up to seven buffers. The
/// destinations must stay alive and untouched until `wait` returns. Made before a launch's
/// queued writes (GrowBuffer::put), it also keeps their sources alive: declared after them, it
/// is destroyed first, and unless `wait` ran it drains the queue (an exception between the
/// writes and the wait must not free what the driver still reads).
class BatchedReads {
 public:
  explicit BatchedReads(boost::compute::command_queue& q) : q_(q) {}
  BatchedReads(const BatchedReads&) = delete;
  BatchedReads& operator=(const BatchedReads&) = delete;
  /// Waits for what is still queued, without throwing: a failure has already been reported by
  /// the call that threw.
  ~BatchedReads() {
    if (pending_) clFinish(q_.get());
  }
  void bytes(const boost::compute::buffer& b, std::size_t n, void* dst) {
    if (n == 0) return;
    cl_call("clEnqueueReadBuffer", [&] { q_.enqueue_read_buffer_async(b, 0, n, dst); });
  }
  template <class T>
  void read(const boost::compute::buffer& b, std::vector<T>& v) {
    bytes(b, v.size() * sizeof(T), v.data());
  }
  void wait() {
    cl_call("clFinish", [&] { q_.finish(); });
    pending_ = false;
  }

 private:
  boost::compute::command_queue& q_;
  bool pending_ = true;
};

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
  const char* label;  ///< names the buffer in an allocation error
  boost::compute::buffer buf;
  std::size_t bytes = 0;
  explicit GrowBuffer(const char* name) : label(name) {}
  /// The buffer, grown (by a quarter more than asked, so that slowly growing inputs do not
  /// reallocate every time) to hold at least `need` bytes; its contents are undefined.
  boost::compute::buffer& get(boost::compute::context& cx, std::size_t need) {
    need = std::max(need, kMinBufferBytes);
    if (need > bytes) {
      // The old buffer goes first: holding both would need the old size more than the new.
      buf = boost::compute::buffer();
      bytes = 0;
      buf = device_buffer(cx, need + need / 4, label);
      bytes = need + need / 4;
    }
    return buf;
  }
  /// The buffer, grown to hold v, with v's write to its start queued, not waited for (a
  /// blocking write is a round trip through the driver's threads, see BatchedReads): v must
  /// stay alive and unchanged until the queue has run it, which the next blocking call on q
  /// (a read, BatchedReads::wait, a finish) ensures.
  template <class T>
  boost::compute::buffer& put(boost::compute::context& cx, boost::compute::command_queue& q,
                              const std::vector<T>& v) {
    boost::compute::buffer& b = get(cx, v.size() * sizeof(T));
    if (v.empty()) return b;
    try {
      q.enqueue_write_buffer_async(b, 0, v.size() * sizeof(T), v.data());
    } catch (const boost::compute::opencl_error& e) {
      throw OpenCLError(e.error_code(),
                        buffer_call("clEnqueueWriteBuffer", cx, label, v.size() * sizeof(T)));
    }
    return b;
  }
};

/// n rounded up to a whole number of m (m > 0): the global size of a 1D launch.
inline std::size_t round_up(std::size_t n, std::size_t m) {
  return (n + m - 1) / m * m;
}

}  // namespace potmap::detail
