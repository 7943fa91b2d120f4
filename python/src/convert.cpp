#include "convert.hpp"

#include <algorithm>
#include <sstream>

namespace potmap::python {

namespace {

py::array as_array(py::handle obj, const char* name) {
  if (obj.is_none()) throw py::type_error(std::string(name) + ": expected an array, got None");
  py::array a;
  try {
    a = py::array::ensure(obj);
  } catch (py::error_already_set&) {
    a = py::array();
  }
  if (!a) {
    throw py::type_error(std::string(name) + ": expected an array, got " +
                         std::string(py::str(py::type::of(obj).attr("__name__"))));
  }
  return a;
}

std::string shape_text(const py::array& a) {
  std::ostringstream s;
  s << "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s << (i ? ", " : "") << a.shape(i);
  s << (a.ndim() == 1 ? ",)" : ")");
  return s.str();
}

std::string dtype_text(const py::array& a) {
  return py::str(a.dtype());
}

// Floats of either width; other kinds are a TypeError rather than a silent cast.
void require_float(const py::array& a, const char* name) {
  char kind = a.dtype().kind();
  if (kind != 'f' || (a.itemsize() != 4 && a.itemsize() != 8)) {
    throw py::type_error(std::string(name) + ": dtype " + dtype_text(a) +
                         " is not supported, use float64 or float32");
  }
}

}  // namespace

Points points_arg(py::handle obj, int dim, const char* name) {
  py::array a = as_array(obj, name);
  if (a.size() == 0 && a.ndim() <= 1) {
    // An empty list or array: no points (np.asarray([]) is float64 of shape (0,)).
    Points p;
    p.array = py::array_t<double, py::array::c_style>(std::vector<py::ssize_t>{0, dim ? dim : 2});
    return p;
  }
  require_float(a, name);
  bool dim_ok = a.ndim() == 2 && (dim ? a.shape(1) == dim : (a.shape(1) == 2 || a.shape(1) == 3));
  if (!dim_ok) {
    throw py::value_error(std::string(name) + ": expected shape (n, " +
                          (dim ? std::to_string(dim) : std::string("2 or 3")) + "), got " +
                          shape_text(a));
  }
  Points p;
  p.array = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  p.data = p.array.data();
  p.n = static_cast<std::size_t>(a.shape(0));
  return p;
}

std::vector<double> doubles_arg(py::handle obj, long n, const char* name) {
  py::array a = as_array(obj, name);
  if (a.size() == 0 && a.ndim() <= 1 && n <= 0) return {};
  require_float(a, name);
  if (a.ndim() != 1 || (n >= 0 && a.shape(0) != n)) {
    throw py::value_error(std::string(name) + ": expected shape (" +
                          (n >= 0 ? std::to_string(n) : std::string("n")) + ",), got " +
                          shape_text(a));
  }
  auto c = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  return std::vector<double>(c.data(), c.data() + c.size());
}

std::vector<std::uint8_t> labels_arg(py::handle obj, long n, const char* name) {
  py::array a = as_array(obj, name);
  if (a.size() == 0 && a.ndim() <= 1 && n <= 0) return {};
  char kind = a.dtype().kind();
  if (kind != 'b' && kind != 'i' && kind != 'u' && kind != 'f') {
    throw py::type_error(std::string(name) + ": dtype " + dtype_text(a) +
                         " is not supported, use bool, an integer type or float (0 or 1)");
  }
  bool shape_ok = a.ndim() == 1 || (a.ndim() == 2 && a.shape(1) == 1);
  if (!shape_ok || (n >= 0 && a.shape(0) != n)) {
    throw py::value_error(std::string(name) + ": expected shape (" +
                          (n >= 0 ? std::to_string(n) : std::string("n")) + ",), got " +
                          shape_text(a));
  }
  auto c = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(a);
  std::vector<std::uint8_t> out(static_cast<std::size_t>(c.size()));
  for (std::size_t i = 0; i < out.size(); ++i) {
    double v = c.data()[i];
    if (v != 0.0 && v != 1.0) {
      throw py::value_error(std::string(name) + ": label " + std::to_string(i) + " is " +
                            std::to_string(v) + ", expected 0 or 1");
    }
    out[i] = v != 0.0;
  }
  return out;
}

py::array_t<double> points_array(const std::vector<double>& v, int dim) {
  py::ssize_t d = dim > 0 ? dim : 1;
  return to_array(v, {static_cast<py::ssize_t>(v.size()) / d, d});
}

void set_fields(py::object obj, const py::dict& kwargs, const char* what,
                const std::vector<std::string>& fixed) {
  py::object type = py::type::of(obj);
  py::object property = py::module_::import("builtins").attr("property");
  for (auto item : kwargs) {
    std::string key = py::str(item.first);
    bool known = py::hasattr(type, key.c_str()) && py::isinstance(type.attr(key.c_str()), property);
    if (!known || std::find(fixed.begin(), fixed.end(), key) != fixed.end()) {
      throw py::type_error(std::string(what) + ": unexpected keyword argument '" + key + "'");
    }
    obj.attr(key.c_str()) = item.second;
  }
}

void add_fields_repr(py::object cls) {
  py::object property = py::module_::import("builtins").attr("property");
  py::list fields;
  // A class's __dict__ is a mappingproxy, not a dict: borrowed as one it iterates as empty.
  for (auto item : py::dict(cls.attr("__dict__"))) {
    std::string key = py::str(item.first);
    if (key[0] != '_' && py::isinstance(item.second, property)) fields.append(key);
  }
  std::string name = py::str(cls.attr("__name__"));
  cls.attr("__repr__") = py::cpp_function(
      [fields, name](py::object self) {
        std::string s = name + "(";
        bool first = true;
        for (auto f : fields) {
          std::string key = py::str(f);
          s += (first ? "" : ", ") + key + "=" + std::string(py::repr(self.attr(key.c_str())));
          first = false;
        }
        return s + ")";
      },
      py::is_method(cls));
}

}  // namespace potmap::python
