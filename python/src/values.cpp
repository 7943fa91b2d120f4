#include "values.hpp"

namespace potmap::python {

namespace py = pybind11;

void bind_values(py::module_& m) {
  py::class_<Values>(m, "Values",
                     "Probability, mean and variance of a map at points or on a raster.\n"
                     "Unpacks as (prob, mean, var).")
      .def_readonly("prob", &Values::prob, "occupancy probability in [0, 1]")
      .def_readonly("mean", &Values::mean, "logit mean mu(x)")
      .def_readonly("var", &Values::var, "logit variance s2(x)")
      .def("__iter__",
           [](const Values& v) { return py::iter(py::make_tuple(v.prob, v.mean, v.var)); })
      .def("__len__", [](const Values&) { return 3; })
      .def("__repr__", [](const Values& v) {
        return "<potmap.Values of shape " + std::string(py::str(v.prob.attr("shape"))) + ">";
      });
}

}  // namespace potmap::python
