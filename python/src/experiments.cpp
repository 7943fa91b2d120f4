// The paper's experiment methods (include/potmap/experiments/experiment.hpp): one task, every
// method fitted on its training beams and scored on the same held-out samples.

#include <pybind11/stl.h>

#include <iostream>

#include "bindings.hpp"
#include "convert.hpp"
#include "potmap/experiments/default_dictionary.hpp"
#include "potmap/experiments/experiment.hpp"

namespace potmap::python {

namespace py = pybind11;
using namespace pybind11::literals;
namespace ex = potmap::experiment;

namespace {

std::vector<Scan> scan_list(py::handle scans) {
  if (py::hasattr(scans, "scans") && !py::isinstance<py::list>(scans)) {
    return scans.attr("scans").cast<std::vector<Scan>>();
  }
  return scans.cast<std::vector<Scan>>();
}

// MapTask and making one from scans.
void bind_experiment_tasks(py::module_& e) {
  py::class_<ex::MapTask>(e, "MapTask",
                          "What a method may learn from (never the held-out samples).")
      .def_readonly("dim", &ex::MapTask::dim)
      .def_readonly("first_index", &ex::MapTask::first_index)
      .def_readwrite("source", &ex::MapTask::source,
                     "source places: lists of Scan (transfer methods)")
      .def_readwrite("source_key", &ex::MapTask::source_key, "names the source for atom reuse")
      .def_readonly("train_scans", &ex::MapTask::train_scans, "target scans, training beams only")
      .def_readonly("train", &ex::MapTask::train, "their labelled samples")
      .def_property_readonly(
          "lo", [](const ex::MapTask& t) { return std::vector<double>(t.lo, t.lo + t.dim); })
      .def_property_readonly(
          "hi", [](const ex::MapTask& t) { return std::vector<double>(t.hi, t.hi + t.dim); })
      .def_readwrite("seed", &ex::MapTask::seed);

  e.def(
      "make_task",
      [](py::handle scans, double free_per_metre, double holdout, std::uint64_t seed,
         double area_margin, std::int64_t first_index, py::object source) {
        std::vector<Scan> v = scan_list(scans);
        LabelOptions o;
        o.free_per_metre = free_per_metre;
        o.holdout_fraction = holdout;
        o.seed = seed;
        LabelledPoints test;
        ex::MapTask task;
        {
          py::gil_scoped_release release;
          task = ex::make_task(v, o, test, area_margin, first_index);
        }
        task.seed = seed;
        if (!source.is_none()) {
          for (auto place : source) task.source.push_back(scan_list(place));
        }
        return py::make_tuple(task, test);
      },
      "scans"_a, "free_per_metre"_a = 1.0, "holdout"_a = 0.2, "seed"_a = 0, "area_margin"_a = 5.0,
      "first_index"_a = 0, "source"_a = py::none(),
      "Labels scans (holdout of each scan's beams held out, default 0.2) and returns\n"
      "(task, test): the task from the training beams, test the held-out LabelledPoints.\n"
      "area_margin: metres around the hits (5). source: list of places (lists of Scan) for\n"
      "the transfer methods.");
  e.def("limit_range", &ex::limit_range, "scan"_a, "max_range"_a,
        "The scan with returns beyond max_range metres turned into no-returns.");
}

// FittedMap and Method: what a method learns, and the method itself.
void bind_experiment_method_types(py::module_& e) {
  py::class_<ex::FittedMap>(e, "FittedMap", "A learned map as the evaluation sees it.")
      .def(
          "query",
          [](const ex::FittedMap& f, py::handle points, int dim) {
            Points p = points_arg(points, dim, "points");
            auto n = static_cast<py::ssize_t>(p.n);
            py::array_t<double> prob(n), var(n);
            double *pp = prob.mutable_data(), *pv = var.mutable_data();
            {
              py::gil_scoped_release release;
              f.query(p.data, p.n, pp, pv);
            }
            return py::make_tuple(prob, var);
          },
          "points"_a, "dim"_a = 2,
          "(prob, var) float64 at (n, dim) points; var NaN where the model has none (OGM).")
      .def_property_readonly(
          "kernels",
          [](const ex::FittedMap& f) -> py::object {
            if (!f.kernels) return py::none();
            return py::cast(*f.kernels);
          },
          "the KernelMap (copy) of kernel maps, else None")
      .def_readonly("fit_seconds", &ex::FittedMap::fit_seconds, "wall time of learning")
      .def_readonly("info", &ex::FittedMap::info, "method-specific numbers");

  py::class_<ex::Method>(e, "Method", "A mapping method of the experiments.")
      .def_readonly("name", &ex::Method::name)
      .def_readonly("group", &ex::Method::group)
      .def_readonly("uses_source", &ex::Method::uses_source)
      .def(
          "fit",
          [](const ex::Method& mt, Context* ctx,
             ex::MapTask task) {  // copied under the GIL: its fields are writable
            py::gil_scoped_release release;
            return mt.fit(ctx, task);
          },
          "ctx"_a, "task"_a, py::keep_alive<0, 2>(),
          "Learns a map from the task (ctx None: CPU references where the method has them).");
}

// BhmSetup, AbhmSetup and PotSetup: the methods' settings.
void bind_experiment_setups(py::module_& e) {
  py::class_<ex::BhmSetup> bhm(e, "BhmSetup", "BHM settings of the experiments.");
  bhm.def(py::init([](const py::kwargs& kw) { return options_from<ex::BhmSetup>(kw, "BhmSetup"); }))
      .def_readwrite("joint", &ex::BhmSetup::joint, "joint posterior (True) or diagonal")
      .def_readwrite("spacing", &ex::BhmSetup::spacing, "grid spacing, metres (0.5)")
      .def_readwrite("gamma", &ex::BhmSetup::gamma, "1/m^2 (0: the model's default)")
      .def_readwrite("count", &ex::BhmSetup::count, "> 0: spacing for about this many kernels")
      .def_readwrite("options", &ex::BhmSetup::options, "BhmOptions")
      .def_readwrite("prior_var", &ex::BhmSetup::prior_var, "0: the model's default")
      .def_readwrite("bias", &ex::BhmSetup::bias, "a bias weight (True)");
  add_fields_repr(bhm);
  py::class_<ex::AbhmSetup> abhm(e, "AbhmSetup", "ABHM settings of the experiments.");
  abhm.def(py::init(
               [](const py::kwargs& kw) { return options_from<ex::AbhmSetup>(kw, "AbhmSetup"); }))
      .def_readwrite("count", &ex::AbhmSetup::count, "kernels (1000)")
      .def_readwrite("gamma0", &ex::AbhmSetup::gamma0, "starting width, 1/m^2 (1)")
      .def_readwrite("steps", &ex::AbhmSetup::steps, "Adam steps (2450)")
      .def_readwrite("batch", &ex::AbhmSetup::batch, "samples per step (256)");
  add_fields_repr(abhm);
  py::class_<ex::PotSetup> potset(e, "PotSetup", "POT / RePOT settings of the experiments.");
  potset
      .def(
          py::init([](const py::kwargs& kw) { return options_from<ex::PotSetup>(kw, "PotSetup"); }))
      .def_readwrite("pot", &ex::PotSetup::pot, "PotOptions (the library's defaults)")
      .def_readwrite("atom_map", &ex::PotSetup::atom_map, "'bhm' (default) or 'abhm'")
      .def_readwrite("atom_bhm", &ex::PotSetup::atom_bhm)
      .def_readwrite("atom_abhm", &ex::PotSetup::atom_abhm)
      .def_readwrite("atom_scans", &ex::PotSetup::atom_scans,
                     "source scans per place cut into atoms (10)")
      .def_readwrite("persistent_refine", &ex::PotSetup::persistent_refine, "(True)")
      .def_readwrite("target_bhm", &ex::PotSetup::target_bhm)
      .def_readwrite("seed_min_variance", &ex::PotSetup::seed_min_variance, "(10)")
      .def_readwrite("dictionary", &ex::PotSetup::dictionary, "DictionaryOptions")
      .def_readwrite("overall", &ex::PotSetup::overall, "OverallMapOptions")
      .def_readwrite("pipeline", &ex::PotSetup::pipeline, "(True)");
  add_fields_repr(potset);
}

// The methods, and scoring and drawing what they learn.
void bind_experiment_methods(py::module_& e) {
  e.def("ogm_method", &ex::ogm_method, "resolution"_a, "OctoMap occupancy grid, cells in metres.");
  e.def(
      "bhm_method",
      [](py::object setup, const std::string& name, const py::kwargs& kw) {
        ex::BhmSetup s = setup.is_none() ? options_from<ex::BhmSetup>(kw, "bhm_method")
                                         : setup.cast<ex::BhmSetup>();
        return ex::bhm_method(s, name);
      },
      "setup"_a = py::none(), "name"_a = "BHM", "Online BHM (BhmSetup or its fields as keywords).");
  e.def(
      "abhm_method",
      [](py::object setup, const std::string& name, const py::kwargs& kw) {
        ex::AbhmSetup s = setup.is_none() ? options_from<ex::AbhmSetup>(kw, "abhm_method")
                                          : setup.cast<ex::AbhmSetup>();
        return ex::abhm_method(s, name);
      },
      "setup"_a = py::none(), "name"_a = "ABHM",
      "Offline ABHM (AbhmSetup or its fields as keywords).");
  e.def(
      "pot_method",
      [](py::object setup, bool refine, py::object name) {
        ex::PotSetup s = setup.is_none() ? ex::PotSetup{} : setup.cast<ex::PotSetup>();
        if (refine) s.pot.refine = true;
        std::string n =
            name.is_none() ? (s.pot.refine ? "RePOT" : "POT") : name.cast<std::string>();
        return ex::pot_method(s, n);
      },
      "setup"_a = py::none(), "refine"_a = false, "name"_a = py::none(),
      "POT (refine False) or RePOT as a method; uses the task's source places.");
  e.def(
      "score_map",
      [](const ex::FittedMap& f, const LabelledPoints& test) {
        py::gil_scoped_release release;
        return ex::score_map(f, test);
      },
      "map"_a, "test"_a, "ACC, AUC and NLL of a fitted map on labelled points.");
  e.def(
      "write_figures",
      [](const ex::FittedMap& f, const std::vector<double>& lo, const std::vector<double>& hi,
         const std::string& prefix, std::size_t max_pixels, int dim) {
        if (lo.size() < 2 || hi.size() < 2) throw py::value_error("lo, hi: at least x and y");
        if (dim == 0) dim = f.kernels ? f.kernels->dim : 2;
        double l[3] = {lo[0], lo[1], lo.size() > 2 ? lo[2] : 0},
               h[3] = {hi[0], hi[1], hi.size() > 2 ? hi[2] : 0};
        py::gil_scoped_release release;
        return ex::write_figures(f, dim, l, h, prefix, max_pixels);
      },
      "map"_a, "lo"_a, "hi"_a, "prefix"_a, "max_pixels"_a = 400, "dim"_a = 0,
      "PREFIX_prob.png, PREFIX_var.png, PREFIX_kernels.png of a fitted map of dimension dim (0: "
      "its kernels', else 2; a 3D map at the height halfway between lo and hi); returns the "
      "files.");
}

// The built-in dictionary, at the module's top level: what `potmap dict default` gives the
// command line (the mapping job that uses it: job.cpp).
void bind_recording(py::module_& m) {
  m.def(
      "default_dictionary",
      [](int dim) {
        ex::DefaultDictionaryNotes notes;
        // Building takes a minute or more: say so, as the command does.
        notes.note = [](const std::string& line) { std::cerr << "potmap: " << line << "\n"; };
        py::gil_scoped_release release;
        return std::make_shared<Dictionary>(ex::default_dictionary(dim, nullptr, notes));
      },
      "dim"_a = 2,
      "The built-in dictionary of dimension dim (2 or 3): atoms of the three simulated towns,\n"
      "built once and cached in $XDG_CACHE_HOME/potmap/dictionaries (else ~/.cache/potmap),\n"
      "the same file `potmap dict default`, `potmap map` and `potmap mapping` read.");
  m.def("default_dictionary_path", &ex::default_dictionary_path, "dim"_a = 2,
        "Where the default dictionary of dimension dim is cached ('' without a cache folder).");
}

}  // namespace

void bind_experiments(py::module_& m) {
  bind_recording(m);
  py::module_ e =
      m.def_submodule("experiment", "The paper's comparisons (Sec. IV): tasks and methods.");

  bind_experiment_tasks(e);
  bind_experiment_method_types(e);
  bind_experiment_setups(e);
  bind_experiment_methods(e);
}

}  // namespace potmap::python
