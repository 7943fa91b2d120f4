// The mapping job (include/potmap/job/mapping_job.hpp): what `potmap mapping` runs, for
// potmap.map_recording() (python/potmap/__init__.py).
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "convert.hpp"
#ifdef POTMAP_PY_EXPERIMENTS
#include "potmap/experiments/default_dictionary.hpp"
#endif
#include "potmap/job/mapping_job.hpp"
#include "potmap/runtime/context.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace potmap::python {

namespace {

void bind_job_options(py::module_& m) {
  using O = MappingJobOptions;
  py::class_<O> o(m, "MappingJobOptions",
                  "How map_recording() maps (`potmap mapping`'s options; units and defaults in "
                  "include/potmap/job/mapping_job.hpp).");
  o.def(py::init([](const py::kwargs& kw) { return options_from<O>(kw, "MappingJobOptions"); }))
      .def_readwrite("out", &O::out, "output folder (created)")
      .def_readwrite("method", &O::method,
                     "'' (by the recording: repot for 2D logs, bhm for 3D drives), repot, pot "
                     "or bhm")
      .def_readwrite("dictionary", &O::dictionary, ".potdict ('' the built-in one)")
      .def_readwrite("range_cut", &O::range_cut, "metres (-1: 20 in 2D, 40 in 3D; 0: none)")
      .def_readwrite("first", &O::first, "scans or keyframes skipped")
      .def_readwrite("max_scans", &O::max_scans, "at most this many mapped (0: all)")
      .def_readwrite("seed", &O::seed)
      .def_readwrite("half_life", &O::half_life, "forgetting, seconds (0: never)")
      .def_readwrite("picture_pixels", &O::picture_pixels)
      .def_readwrite("preset", &O::preset, "2D: default or paper")
      .def_readwrite("ranking", &O::ranking, "2D: '' (the preset's), indexed or exhaustive")
      .def_readwrite("rotations", &O::rotations, "2D: rotations tried per atom")
      .def_readwrite("seeds_yield_fully", &O::seeds_yield_fully)
      .def_readwrite("ros_resolution", &O::ros_resolution, "2D: the ROS map's metres a pixel")
      .def_readwrite("poses", &O::poses, "3D: odom, optimized or auto")
      .def_readwrite("band_low", &O::band_low, "3D: metres about the sensor's height")
      .def_readwrite("band_high", &O::band_high, "3D: metres about the sensor's height")
      .def_readwrite("voxel", &O::voxel, "3D: the exports' voxel edge, metres")
      .def_readwrite("picture_res", &O::picture_res, "3D: band pictures' metres a pixel")
      .def_readwrite("checkpoint_every", &O::checkpoint_every, "3D: keyframes (0: not by count)")
      .def_readwrite("checkpoint_seconds", &O::checkpoint_seconds, "3D: seconds (0: not by time)")
      .def_readwrite("export_every", &O::export_every, "3D: keyframes between exports")
      .def_readwrite("transfer_every", &O::transfer_every, "3D RePOT: keyframes")
      .def_readwrite("sums", &O::sums, "3D: auto, host or device")
      .def_readwrite("resume", &O::resume, "3D: continue from OUT/map.ckpt")
      .def_readwrite("keep_checkpoint", &O::keep_checkpoint)
      .def_readwrite("keep_tiles", &O::keep_tiles)
      .def_readwrite("lookahead", &O::lookahead,
                     "scores.json's look-ahead (2D logs: RePOT's persistent map)")
      .def_readwrite("bag", &O::bag, "ROS bags: BagOptions");
  add_fields_repr(o);

  py::class_<JobProgress>(m, "JobProgress", "Where a mapping job stands.")
      .def_readonly("stage", &JobProgress::stage, "mapping, outputs, export or dictionary")
      .def_readonly("unit", &JobProgress::unit, "scan, keyframe or share")
      .def_readonly("done", &JobProgress::done)
      .def_readonly("total", &JobProgress::total)
      .def_readonly("elapsed_s", &JobProgress::elapsed_s)
      .def_readonly("detail", &JobProgress::detail, "the unit just done, one line")
      .def_property_readonly("fraction", &JobProgress::fraction);

  py::class_<MappingJobResult>(m, "MappingJobResult", "What a mapping job wrote.")
      .def_readonly("drive", &MappingJobResult::drive, "a 3D drive (else a 2D log)")
      .def_readonly("files", &MappingJobResult::files, "every file written, scores.json last")
      .def_readonly("scores", &MappingJobResult::scores, "held-out beams on the final map")
      .def_readonly("lookahead", &MappingJobResult::lookahead,
                    "options lookahead: held-out samples on the map before their scan or keyframe")
      .def_readonly("lookahead_beyond", &MappingJobResult::lookahead_beyond,
                    "those of them beyond every earlier sample's reach")
      .def_readonly("scores_json", &MappingJobResult::scores_json, "scores.json's text");
}

}  // namespace

void bind_job(py::module_& m) {
  bind_job_options(m);
  m.def(
      "_run_mapping_job",
      [](const std::string& path, Context& ctx, const MappingJobOptions& options, py::object note,
         py::object progress) {
        MappingJobHooks hooks;
        // The callbacks run on the job's threads with the GIL released: each takes it. A
        // Python exception (Ctrl-C among them, checked at every report) stops the job.
        if (!note.is_none())
          hooks.note = [note](const std::string& line) {
            py::gil_scoped_acquire gil;
            note(line);
          };
        hooks.progress = [progress](const JobProgress& p) {
          py::gil_scoped_acquire gil;
          if (PyErr_CheckSignals() != 0) throw py::error_already_set();
          if (!progress.is_none()) progress(p);
        };
#ifdef POTMAP_PY_EXPERIMENTS
        // Built when missing (a few seconds, once), as potmap.default_dictionary().
        // Runs without the GIL: `note` is used through a pointer (a copy would count
        // references without it); it outlives the job.
        const py::object* note_fn = note.is_none() ? nullptr : &note;
        hooks.default_dictionary = [note_fn](int dim, std::string* where) {
          experiment::DefaultDictionaryNotes notes;
          if (note_fn)
            notes.note = [note_fn](const std::string& line) {
              py::gil_scoped_acquire gil;
              (*note_fn)(line);
            };
          return experiment::default_dictionary(dim, where, notes);
        };
#endif
        py::gil_scoped_release release;
        return run_mapping_job(ctx, path, options, hooks);
      },
      "path"_a, "ctx"_a, "options"_a, "note"_a = py::none(), "progress"_a = py::none(),
      "map_recording() without its defaults (see map_recording).");
  m.def("default_mapping_folder", &default_mapping_folder, "recording"_a,
        "Where `potmap mapping` writes when given no folder: out/mapping/<recording's name>.");
}

}  // namespace potmap::python
