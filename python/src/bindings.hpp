#pragma once
// One bind_* function per concern, each in its own file (python/src/<concern>.cpp), called in
// this order by module.cpp: later concerns use the types earlier ones registered.

#include <pybind11/pybind11.h>

namespace potmap::python {

void bind_errors(pybind11::module_& m);
void bind_runtime(pybind11::module_& m);
void bind_map(pybind11::module_& m);
void bind_raster_tiles(pybind11::module_& m);
void bind_io(pybind11::module_& m);
void bind_data(pybind11::module_& m);
void bind_bags(pybind11::module_& m);
void bind_learn(pybind11::module_& m);
void bind_ot(pybind11::module_& m);
void bind_pot(pybind11::module_& m);
void bind_drives(pybind11::module_& m);
void bind_experiments(pybind11::module_& m);
void bind_job(pybind11::module_& m);

}  // namespace potmap::python
