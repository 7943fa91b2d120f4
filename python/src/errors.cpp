// potmap's exceptions as Python exceptions carrying the same message (file, line or offset and
// value). ArgumentError and InputError are ValueErrors too, so that code catching the built-in
// class works; OpenCLError carries the status code and its name.

#include <Python.h>

#include "bindings.hpp"
#include "potmap/error.hpp"

namespace potmap::python {

namespace py = pybind11;

namespace {

py::object new_exception(py::module_& m, const char* name, py::tuple bases, const char* doc) {
  std::string qualified = std::string("potmap.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, bases.ptr(), nullptr);
  if (!type) throw py::error_already_set();
  py::object t = py::reinterpret_steal<py::object>(type);
  m.attr(name) = t;
  return t;
}

// The classes are looked up in the module at the time of the error: no static Python objects.
void raise(const char* name, const std::exception& e, const potmap::OpenCLError* cl = nullptr) {
  py::object type = py::module_::import("potmap._potmap").attr(name);
  py::object value = type(e.what());
  if (cl) {
    value.attr("code") = cl->code();
    value.attr("name") = cl->name();
  }
  PyErr_SetObject(type.ptr(), value.ptr());
}

}  // namespace

void bind_errors(py::module_& m) {
  py::object builtins = py::module_::import("builtins");
  py::object error = new_exception(m, "Error", py::make_tuple(builtins.attr("RuntimeError")),
                                   "Base class of every exception potmap raises.");
  new_exception(m, "InputError", py::make_tuple(error, builtins.attr("ValueError")),
                "Bad input data; the message names the file, the line or byte offset and the "
                "value.");
  new_exception(m, "ArgumentError", py::make_tuple(error, builtins.attr("ValueError")),
                "An argument outside its documented range.");
  py::object cl = new_exception(m, "OpenCLError", py::make_tuple(error),
                                "An OpenCL call failed; .code is the status (e.g. -5), .name "
                                "its symbolic name (e.g. 'CL_OUT_OF_RESOURCES').");
  new_exception(m, "BuildError", py::make_tuple(cl),
                "A kernel failed to compile; the message carries the build log.");

  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const potmap::BuildError& e) {
      raise("BuildError", e, &e);
    } catch (const potmap::OpenCLError& e) {
      raise("OpenCLError", e, &e);
    } catch (const potmap::InputError& e) {
      raise("InputError", e);
    } catch (const potmap::ArgumentError& e) {
      raise("ArgumentError", e);
    } catch (const potmap::Error& e) {
      raise("Error", e);
    }
  });
}

}  // namespace potmap::python
