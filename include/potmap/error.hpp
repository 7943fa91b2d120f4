#pragma once
// Exceptions thrown by potmap. Everything potmap throws derives from potmap::Error.

#include <cstdint>
#include <stdexcept>
#include <string>

#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// Base class of every potmap exception.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An OpenCL call failed. `code()` is the OpenCL status (e.g. -5), `name()` its symbolic name
/// (e.g. "CL_OUT_OF_RESOURCES"); what() names the call that failed as well.
class OpenCLError : public Error {
 public:
  OpenCLError(int code, const std::string& where);
  int code() const noexcept { return code_; }
  const std::string& name() const noexcept { return name_; }

 private:
  int code_;
  std::string name_;
};

/// A kernel failed to compile. what() and log() carry the compiler's build log.
class BuildError : public OpenCLError {
 public:
  BuildError(int code, const std::string& kernel, const std::string& options,
             const std::string& log);
  const std::string& log() const noexcept { return log_; }

 private:
  std::string log_;
};

/// Bad input data: what() names the file, the position (line or byte offset) and the value.
class InputError : public Error {
 public:
  using Error::Error;
};

/// An argument outside its documented range (wrong dimension, negative size, ...).
class ArgumentError : public Error {
 public:
  using Error::Error;
};

/// Symbolic name of an OpenCL status code ("CL_INVALID_VALUE"), or "CL_UNKNOWN_ERROR(<code>)".
std::string opencl_error_name(int code);

}  // namespace potmap
POTMAP_CXX_API_END
