// Map files (include/potmap/io/map_io.hpp) and labelled-sample CSV files.

#include <pybind11/stl.h>

#include <optional>
#include <vector>

#include "bindings.hpp"
#include "potmap/data/labelled_points.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/mapping/map_files.hpp"

namespace potmap::python {

namespace py = pybind11;
using namespace pybind11::literals;

void bind_io(py::module_& m) {
  using release = py::call_guard<py::gil_scoped_release>;
  m.def("read_map", &read_map, "path"_a, release(),
        "Reads a KernelMap; the format follows the extension: .csv (x,y[,z],gamma,w_mean,w_var),\n"
        ".npz (as the paper's authors saved maps) or .potmap (native, CRC-checked).\n"
        "InputError naming the file, line or byte offset and value on bad content.");
  // The map is copied while the GIL is held, so that no other thread changes it meanwhile.
  m.def(
      "write_map",
      [](const KernelMap& map, const std::string& path) {
        KernelMap copy = map;
        py::gil_scoped_release unlocked;
        write_map(copy, path);
      },
      "map"_a, "path"_a,
      "Writes a KernelMap as .csv, .npz or .potmap (by extension), through a temporary file\n"
      "and a rename. ArgumentError for an unknown extension or an invalid map.");
  m.def(
      "merge_maps",
      [](const std::vector<std::string>& paths, const std::string& out, bool allow_overlap) {
        py::gil_scoped_release unlocked;
        JointBhmMergeOptions o;
        o.allow_overlap = allow_overlap;
        merge_map_files(paths, out, o);
      },
      "paths"_a, "out"_a, "allow_overlap"_a = false,
      "Merges .potmap maps of overlapping places: joint BHM maps (RePOT's persistent maps, a\n"
      "drive's joint BHM) exactly in information form (precisions and information vectors\n"
      "added, the prior counted once, the means solved again), POT's averaged maps by adding\n"
      "their anchors' sums; writes `out` (.potmap) ready to merge again.\n"
      "InputError for a map written without its information form; ArgumentError for maps\n"
      "whose kernels or priors differ, or that learned the same scans (allow_overlap=True\n"
      "merges those, counting them twice). docs/merging.md.");
  m.def("read_labelled_csv", &read_labelled_csv, "path"_a, release(),
        "Reads labelled samples `t,x,y[,z],occupied` (header line; columns by name).");
  m.def("write_labelled_csv", &write_labelled_csv, "points"_a, "path"_a, release(),
        "Writes labelled samples as `t,x,y[,z],occupied` (atomically).");
}

}  // namespace potmap::python
