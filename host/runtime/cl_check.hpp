#pragma once
// Translation of Boost.Compute's exceptions into potmap's, at every call site that talks to
// OpenCL, so that callers only ever see potmap::OpenCLError with the call named. Kernel launches
// go through set_kernel_arg(s) and enqueue_1d below, which do the same.

#include <boost/compute/buffer.hpp>
#include <boost/compute/command_queue.hpp>
#include <boost/compute/event.hpp>
#include <boost/compute/exception/opencl_error.hpp>
#include <boost/compute/kernel.hpp>
#include <boost/compute/utility/wait_list.hpp>
#include <cstddef>
#include <string>

#include "potmap/error.hpp"

namespace potmap::detail {

template <class F>
auto cl_call(const char* where, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const boost::compute::opencl_error& e) {
    throw OpenCLError(e.error_code(), where);
  }
}

inline void cl_check(cl_int status, const char* where) {
  if (status != CL_SUCCESS) throw OpenCLError(status, where);
}

/// A struct passed to a kernel by value (its bytes as the argument; the kernel's struct must
/// have the same layout).
template <class T>
struct ByValue {
  const T& value;
};
template <class T>
ByValue<T> by_value(const T& value) {
  return {value};
}

/// Sets argument `index` of kernel `k` (named `name` in the error).
template <class T>
void set_kernel_arg(boost::compute::kernel& k, const char* name, cl_uint index, const T& value) {
  try {
    k.set_arg(index, value);
  } catch (const boost::compute::opencl_error& e) {
    throw OpenCLError(e.error_code(),
                      std::string("clSetKernelArg(") + name + ", " + std::to_string(index) + ")");
  }
}
template <class T>
void set_kernel_arg(boost::compute::kernel& k, const char* name, cl_uint index,
                    const ByValue<T>& arg) {
  try {
    k.set_arg(index, sizeof(T), &arg.value);
  } catch (const boost::compute::opencl_error& e) {
    throw OpenCLError(e.error_code(),
                      std::string("clSetKernelArg(") + name + ", " + std::to_string(index) + ")");
  }
}

/// Sets arguments `first`, `first` + 1, ... of `k` in order.
template <class... Args>
void set_kernel_args_from(boost::compute::kernel& k, const char* name, cl_uint first,
                          const Args&... args) {
  (set_kernel_arg(k, name, first++, args), ...);
}

/// Sets the arguments of `k` in order, from argument 0.
template <class... Args>
void set_kernel_args(boost::compute::kernel& k, const char* name, const Args&... args) {
  set_kernel_args_from(k, name, 0, args...);
}

/// Enqueues `k` over `global` work-items in work-groups of `local` (0: the driver's choice),
/// after `events`; returns the launch's event.
inline boost::compute::event enqueue_1d(boost::compute::command_queue& q, boost::compute::kernel& k,
                                        const char* name, std::size_t global, std::size_t local,
                                        const boost::compute::wait_list& events = {}) {
  try {
    return q.enqueue_1d_range_kernel(k, 0, global, local, events);
  } catch (const boost::compute::opencl_error& e) {
    throw OpenCLError(e.error_code(), std::string("clEnqueueNDRangeKernel(") + name + ")");
  }
}

/// Enqueues `k` over a 2D range of `global` work-items in work-groups of `local`.
inline void enqueue_2d(boost::compute::command_queue& q, boost::compute::kernel& k,
                       const char* name, const std::size_t (&global)[2],
                       const std::size_t (&local)[2]) {
  try {
    q.enqueue_nd_range_kernel(k, 2, nullptr, global, local);
  } catch (const boost::compute::opencl_error& e) {
    throw OpenCLError(e.error_code(), std::string("clEnqueueNDRangeKernel(") + name + ")");
  }
}

/// Sets argument `index` of `k` to `buffer`, or to a null cl_mem when `buffer` is null (for
/// optional outputs the kernel tests for).
inline void set_kernel_arg_or_null(boost::compute::kernel& k, const char* name, cl_uint index,
                                   const boost::compute::buffer* buffer) {
  cl_mem mem = buffer ? buffer->get() : nullptr;
  const cl_int status = clSetKernelArg(k.get(), index, sizeof(cl_mem), mem ? &mem : nullptr);
  if (status != CL_SUCCESS)
    throw OpenCLError(status,
                      std::string("clSetKernelArg(") + name + ", " + std::to_string(index) + ")");
}

/// Sets every argument of `k` and enqueues it: the one way to launch a 1D kernel.
template <class... Args>
void launch_1d(boost::compute::command_queue& q, boost::compute::kernel& k, const char* name,
               std::size_t global, std::size_t local, const Args&... args) {
  set_kernel_args(k, name, args...);
  enqueue_1d(q, k, name, global, local);
}

}  // namespace potmap::detail
