#pragma once
// What evaluating a map returns: probability, mean and variance arrays. Unpacks as a tuple
// (p, mean, var = ...), in that order.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

namespace potmap::python {

struct Values {
  pybind11::array prob, mean, var;
};

void bind_values(pybind11::module_& m);

}  // namespace potmap::python
