#pragma once
// The C API's boundary: every potmap_* function runs its body through guard(), which turns each
// exception into a status code and the thread's last-error message, so none crosses into C.

#include <boost/compute/exception/opencl_error.hpp>

#include <cstdint>
#include <new>
#include <string>
#include <utility>

#include "potmap/error.hpp"
#include "potmap/potmap.h"

namespace potmap::capi {

/// Thrown inside a C API body to fail with a chosen status.
struct Failure {
  potmap_status status;
  std::string message;
};

[[noreturn]] inline void fail(potmap_status status, std::string message) {
  throw Failure{status, std::move(message)};
}

/// Sets the calling thread's last-error message; never throws.
void set_last_error(const char* function, const char* message) noexcept;
void clear_last_error() noexcept;

inline potmap_status report(potmap_status status, const char* function,
                            const char* message) noexcept {
  set_last_error(function, message);
  return status;
}

/// Runs `body`, mapping what it throws to a status. `fallback`: the status for a plain
/// potmap::Error, whose meaning depends on the call (no device, cannot write, ...).
template <class F>
potmap_status guard(const char* function, potmap_status fallback, F&& body) noexcept {
  clear_last_error();
  try {
    body();
    return POTMAP_SUCCESS;
  } catch (const Failure& e) {
    return report(e.status, function, e.message.c_str());
  } catch (const OpenCLError& e) {  // BuildError too: its message carries the build log
    return report(e.code() < 0 ? e.code() : POTMAP_ERROR_INTERNAL, function, e.what());
  } catch (const boost::compute::opencl_error& e) {
    const int code = e.error_code();
    return report(code < 0 ? code : POTMAP_ERROR_INTERNAL, function, e.what());
  } catch (const InputError& e) {
    return report(POTMAP_ERROR_INPUT, function, e.what());
  } catch (const ArgumentError& e) {
    return report(POTMAP_ERROR_INVALID_ARGUMENT, function, e.what());
  } catch (const Error& e) {
    return report(fallback, function, e.what());
  } catch (const std::bad_alloc&) {
    return report(POTMAP_ERROR_OUT_OF_MEMORY, function, "out of host memory");
  } catch (const std::exception& e) {
    return report(POTMAP_ERROR_INTERNAL, function, e.what());
  } catch (...) {
    return report(POTMAP_ERROR_INTERNAL, function, "unknown exception");
  }
}

/// Fails with POTMAP_ERROR_NULL_ARGUMENT naming `what` when `p` is null.
template <class T>
void require(const T* p, const char* what) {
  if (!p) fail(POTMAP_ERROR_NULL_ARGUMENT, std::string(what) + " is null");
}

}  // namespace potmap::capi
