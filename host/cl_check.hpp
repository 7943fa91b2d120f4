#pragma once
// Translation of Boost.Compute's exceptions into potmap's, at every call site that talks to
// OpenCL, so that callers only ever see potmap::OpenCLError with the call named.

#include <boost/compute/exception/opencl_error.hpp>

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

}  // namespace potmap::detail
