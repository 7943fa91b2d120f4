// The compiled part of the potmap package (python/potmap/__init__.py re-exports it).

#include "bindings.hpp"
#include "potmap/version.hpp"

PYBIND11_MODULE(_potmap, m) {
  m.doc() =
      "potmap: continuous occupancy maps (kernel maps, BHM, ABHM, POT and RePOT) on OpenCL "
      "devices, with NumPy arrays in and out. Units are metres and radians throughout.";
  using namespace potmap::python;
  m.attr("__version__") = POTMAP_VERSION_STRING;
  bind_errors(m);
  bind_runtime(m);
  bind_map(m);
  bind_raster_tiles(m);
  bind_io(m);
  bind_data(m);
  bind_learn(m);
  bind_ot(m);
  bind_pot(m);
  bind_drives(m);
  bind_job(m);
#ifdef POTMAP_PY_EXPERIMENTS
  bind_experiments(m);
#endif
}
