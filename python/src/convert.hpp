#pragma once
// NumPy <-> C++ conversions shared by the bindings. Every check raises TypeError (wrong dtype,
// not an array) or ValueError (wrong shape) naming the argument, so that a bad array never
// reaches the library as a bad pointer.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "potmap/data/labelled_points.hpp"
#include "potmap/map/kernel_map.hpp"

namespace potmap::python {

namespace py = pybind11;

/// Points as the library reads them: n rows of `dim` doubles, C order. `array` holds the data
/// (the caller's own array when it already is float64 and C-contiguous: no copy).
struct Points {
  py::array_t<double, py::array::c_style> array;
  const double* data = nullptr;
  std::size_t n = 0;
};

/// An (n, dim) float64 or float32 array (or anything np.asarray makes one of). dim 0: 2 or 3.
Points points_arg(py::handle obj, int dim, const char* name);

/// A 1D float array of exactly n values (n < 0: any length), copied into doubles.
std::vector<double> doubles_arg(py::handle obj, long n, const char* name);

/// Labels: bool, integer or float array of n values (n < 0: any), each 0 or 1.
std::vector<std::uint8_t> labels_arg(py::handle obj, long n, const char* name);

/// Copies into a new NumPy array of the given shape (the C++ object may change later).
template <class T>
py::array_t<T> to_array(const std::vector<T>& v, std::vector<py::ssize_t> shape) {
  py::array_t<T> out(shape);
  if (!v.empty()) std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}
/// (n, dim) array of row-major points.
py::array_t<double> points_array(const std::vector<double>& v, int dim);

/// Sets fields of a bound object from keyword arguments: every keyword must name one of its
/// properties (TypeError otherwise, naming `what` and the keyword) and not one of `fixed`.
void set_fields(py::object obj, const py::dict& kwargs, const char* what,
                const std::vector<std::string>& fixed = {});

/// A plain options struct bound with def_readwrite, filled from keyword arguments.
template <class T>
T options_from(const py::dict& kwargs, const char* what) {
  py::object obj = py::cast(T{});
  set_fields(obj, kwargs, what);
  return obj.cast<T>();
}

/// Defines __repr__ listing every field (property) of an options struct.
void add_fields_repr(py::object cls);

}  // namespace potmap::python
