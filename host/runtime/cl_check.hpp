#pragma once
// Translation of Boost.Compute's exceptions into potmap's, at every call site that talks to
// OpenCL, so that callers only ever see potmap::OpenCLError with the call named. Kernel launches
// go through set_kernel_arg(s) and enqueue_1d below, which do the same.

#include <boost/compute/command_queue.hpp>
#include <boost/compute/exception/opencl_error.hpp>
#include <boost/compute/kernel.hpp>
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

/// Sets the arguments of `k` in order, from argument 0.
template <class... Args>
void set_kernel_args(boost::compute::kernel& k, const char* name, const Args&... args) {
  cl_uint index = 0;
  (set_kernel_arg(k, name, index++, args), ...);
}

/// Enqueues `k` over `global` work-items in work-groups of `local` (0: the driver's choice).
inline void enqueue_1d(boost::compute::command_queue& q, boost::compute::kernel& k,
                       const char* name, std::size_t global, std::size_t local) {
  try {
    q.enqueue_1d_range_kernel(k, 0, global, local);
  } catch (const boost::compute::opencl_error& e) {
    throw OpenCLError(e.error_code(), std::string("clEnqueueNDRangeKernel(") + name + ")");
  }
}

/// Sets every argument of `k` and enqueues it: the one way to launch a 1D kernel.
template <class... Args>
void launch_1d(boost::compute::command_queue& q, boost::compute::kernel& k, const char* name,
               std::size_t global, std::size_t local, const Args&... args) {
  set_kernel_args(k, name, args...);
  enqueue_1d(q, k, name, global, local);
}

}  // namespace potmap::detail
