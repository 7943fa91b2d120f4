// Status names, the per-thread last-error message and the version calls of the C API.
#include <cstdio>
#include <string>

#include "capi_guard.hpp"
#include "potmap/potmap.h"

namespace potmap {
namespace detail {
const char* opencl_error_cname(int code);
}

namespace capi {
namespace {
// Per thread by design: a C caller reads the message of its own last call.
thread_local std::string last_error;
}  // namespace

void set_last_error(const char* function, const char* message) noexcept {
  try {
    last_error.assign(function);
    last_error += ": ";
    last_error += message;
  } catch (...) {
    last_error.clear();  // no room for the message: the status still tells what failed
  }
}

void clear_last_error() noexcept {
  last_error.clear();
}

}  // namespace capi
}  // namespace potmap

extern "C" {

const char* potmap_status_string(potmap_status status) {
  // potmap's own codes are POTMAP_SUCCESS and a run from POTMAP_ERROR_NULL_ARGUMENT, in the
  // order of potmap.h; the negative ones are OpenCL's.
  static constexpr const char* kErrors[] = {"POTMAP_ERROR_NULL_ARGUMENT",
                                            "POTMAP_ERROR_INVALID_HANDLE",
                                            "POTMAP_ERROR_INVALID_ARGUMENT",
                                            "POTMAP_ERROR_DIMENSION_MISMATCH",
                                            "POTMAP_ERROR_BUFFER_TOO_SMALL",
                                            "POTMAP_ERROR_CONTEXT_MISMATCH",
                                            "POTMAP_ERROR_INPUT",
                                            "POTMAP_ERROR_IO",
                                            "POTMAP_ERROR_NO_DEVICE",
                                            "POTMAP_ERROR_OUT_OF_MEMORY",
                                            "POTMAP_ERROR_INTERNAL",
                                            "POTMAP_ERROR_CANCELLED"};
  static_assert(
      POTMAP_ERROR_CANCELLED - POTMAP_ERROR_NULL_ARGUMENT + 1 == sizeof kErrors / sizeof kErrors[0],
      "one name per potmap status");
  if (status == POTMAP_SUCCESS) return "POTMAP_SUCCESS";
  if (status >= POTMAP_ERROR_NULL_ARGUMENT && status <= POTMAP_ERROR_CANCELLED)
    return kErrors[status - POTMAP_ERROR_NULL_ARGUMENT];
  if (status < 0)
    if (const char* name = potmap::detail::opencl_error_cname(status)) return name;
  return "POTMAP_UNKNOWN_STATUS";
}

const char* potmap_last_error(void) {
  return potmap::capi::last_error.c_str();
}

potmap_status potmap_version(int* major, int* minor, int* patch) {
  potmap::capi::clear_last_error();
  if (major) *major = POTMAP_VERSION_MAJOR;
  if (minor) *minor = POTMAP_VERSION_MINOR;
  if (patch) *patch = POTMAP_VERSION_PATCH;
  return POTMAP_SUCCESS;
}

const char* potmap_version_string(void) {
  return POTMAP_VERSION_STRING;
}

}  // extern "C"
