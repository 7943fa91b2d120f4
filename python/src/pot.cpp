// POT and RePOT (include/potmap/pot/): dictionaries of atoms and their files, the transfer of
// one scan, the overall map and the Mapper.

#include <pybind11/stl.h>

#include <cctype>
#include <filesystem>

#include <mutex>
#include <type_traits>

#include "bindings.hpp"
#include "convert.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/mapping/map_files.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/dictionary_io.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/pot/overall_map.hpp"
#include "potmap/pot/transfer.hpp"

namespace potmap::python {

namespace py = pybind11;
using namespace pybind11::literals;

namespace {

// A mapped scan and what adding it did to the overall map, copied out of the Mapper (whose own
// record is replaced by the next scan).
struct ScanStats {
  MappedScan scan;
  MapperMerge merge;
};

// A Mapper is used by one thread at a time, and add_scan() runs without the GIL: its own lock
// makes Python threads sharing one take turns.
struct LockedMapper {
  LockedMapper(Context* ctx, std::shared_ptr<const Dictionary> dict, const MapperOptions& o,
               const OverallMapOptions& overall)
      : mapper(ctx, std::move(dict), o, overall) {}
  Mapper mapper;
  std::mutex mu;
};

// A getter of the Mapper under its lock, returning a copy.
template <class R>
auto locked(R (Mapper::*get)() const) {
  return [get](LockedMapper& lm) {
    std::lock_guard<std::mutex> lock(lm.mu);
    return std::decay_t<R>((lm.mapper.*get)());
  };
}

std::vector<Scan> scans_arg(py::handle scans) {
  if (py::hasattr(scans, "scans") && !py::isinstance<py::list>(scans)) {
    return scans.attr("scans").cast<std::vector<Scan>>();
  }
  return scans.cast<std::vector<Scan>>();
}

using release = py::call_guard<py::gil_scoped_release>;

// SectorOptions, Sector and Atom: how scans are cut, and the atoms cut from them.
void bind_pot_sectors(py::module_& m) {
  py::class_<SectorOptions> sec(m, "SectorOptions", "How scans are cut into sectors.");
  sec.def(py::init([](const py::kwargs& kw) {
       return options_from<SectorOptions>(kw, "SectorOptions");
     }))
      .def_readwrite("sectors", &SectorOptions::sectors, "equal angular sectors (default 5)")
      .def_readwrite("max_range", &SectorOptions::max_range,
                     "sector radius, metres (0: the scan's)")
      .def_readwrite("scale", &SectorOptions::scale,
                     "multiplies centred coordinates (default 1/50)")
      .def_readwrite("min_samples", &SectorOptions::min_samples,
                     "smaller sectors dropped (default 4)");
  add_fields_repr(sec);

  py::class_<Sector>(m, "Sector", "One sector of one scan, centred on its hit centroid and scaled.")
      .def_readonly("dim", &Sector::dim)
      .def_readonly("index", &Sector::index)
      .def_readonly("centre", &Sector::centre, "world-frame centroid, metres")
      .def_readonly("sensor", &Sector::sensor, "world-frame sensor, metres")
      .def_readonly("scale", &Sector::scale)
      .def_readonly("max_range", &Sector::max_range, "metres")
      .def_property_readonly(
          "hits", [](const Sector& s) { return points_array(s.hits, s.dim); },
          "(p - centre) * scale")
      .def_property_readonly(
          "free", [](const Sector& s) { return points_array(s.free, s.dim); },
          "(p - centre) * scale");

  py::class_<Atom>(m, "Atom", "A source sector and its kernels in the sector's frame.")
      .def_readonly("sector", &Atom::sector)
      .def_readonly("kernels", &Atom::kernels, "KernelMap, positions (h - centre) * scale")
      .def_readonly("scan_index", &Atom::scan_index)
      .def_readonly("source", &Atom::source, "provenance text");
}

// DictionaryOptions, Dictionary, and building, reading and writing one.
void bind_pot_dictionary(py::module_& m) {
  py::class_<DictionaryOptions> dopt(m, "DictionaryOptions", "How build_dictionary() proceeds.");
  dopt.def(py::init([](const py::kwargs& kw) {
        return options_from<DictionaryOptions>(kw, "DictionaryOptions");
      }))
      .def_readwrite("sectors", &DictionaryOptions::sectors, "SectorOptions of the cut")
      .def_readwrite("max_weight_variance", &DictionaryOptions::max_weight_variance,
                     "kernels with a larger weight variance are left out (default 1000)")
      .def_readwrite(
          "max_sample_distance", &DictionaryOptions::max_sample_distance,
          "kernels farther from their sector's samples are left out, metres (0: no limit)")
      .def_readwrite(
          "kernels_at_samples", &DictionaryOptions::kernels_at_samples,
          "> 0: atoms' kernels at their own samples thinned to this cell, metres (default 0)")
      .def_readwrite("min_kernels", &DictionaryOptions::min_kernels,
                     "smaller atoms skipped (default 1)")
      .def_readwrite("source", &DictionaryOptions::source, "provenance stored on every atom")
      .def_property(
          "free_per_metre", [](const DictionaryOptions& o) { return o.labels.free_per_metre; },
          [](DictionaryOptions& o, double v) { o.labels.free_per_metre = v; },
          "labelling of the source scans: free samples per metre (default 1)")
      .def_property(
          "seed", [](const DictionaryOptions& o) { return o.labels.seed; },
          [](DictionaryOptions& o, std::uint64_t v) { o.labels.seed = v; },
          "labelling seed (default 0)");
  add_fields_repr(dopt);

  py::class_<Dictionary, std::shared_ptr<Dictionary>>(
      m, "Dictionary", "The dictionary of atoms of POT (SPEC step 1).")
      .def(py::init<>())
      .def_readonly("dim", &Dictionary::dim)
      .def_readonly("scale", &Dictionary::scale, "s shared by every atom")
      .def_readonly("max_range", &Dictionary::max_range, "sector radius, metres")
      .def_readonly("sectors", &Dictionary::sectors, "sectors per source scan")
      .def_readonly("atoms", &Dictionary::atoms, "list of Atom (copies)")
      .def("__len__", &Dictionary::size)
      .def_static("load", &read_dictionary, "path"_a, release(),
                  "Reads a .potdict; InputError names file, byte offset and value.")
      .def(
          "save", [](const Dictionary& d, const std::string& path) { write_dictionary(d, path); },
          "path"_a, release(), "Writes a .potdict through a temporary file and a rename.")
      .def("validate", &validate_dictionary, "source"_a = "");

  m.def(
      "build_dictionary",
      [](py::handle scans, KernelMap map, py::object options, const py::kwargs& kw) {
        std::vector<Scan> v = scans_arg(scans);
        DictionaryOptions o = options.is_none()
                                  ? options_from<DictionaryOptions>(kw, "build_dictionary")
                                  : options.cast<DictionaryOptions>();
        auto dict = std::make_shared<Dictionary>();
        py::gil_scoped_release release;
        build_dictionary(v, map, o, *dict);
        return dict;
      },
      "scans"_a, "map"_a, "options"_a = py::none(),
      "Atoms cut from source scans (list of Scan or a Dataset) and a map learned over the same\n"
      "place (world frame). options: DictionaryOptions, or its fields as keyword arguments\n"
      "(kernels_at_samples=0 m, max_weight_variance=1000, ...).");
  m.def("read_dictionary", &read_dictionary, "path"_a, release());
  m.def("write_dictionary", &write_dictionary, "dictionary"_a, "path"_a, release());
}

// PotOptions: how one scan is transferred.
void bind_pot_options(py::module_& m) {
  py::class_<PotOptions> pot(m, "PotOptions",
                             "Transfer settings (SPEC section 4); the defaults map real logs best\n"
                             "(what `potmap mapping` runs); PotOptions.paper(): the authors'.");
  pot.def(py::init([](const py::kwargs& kw) { return options_from<PotOptions>(kw, "PotOptions"); }))
      .def_static("paper", &PotOptions::paper,
                  "The authors' rules: ranking 'exhaustive', placement 'barycentric',\n"
                  "wall_clearance 0; every other field as the defaults.")
      .def_readwrite("sectors", &PotOptions::sectors, "target sectors per scan (default 5)")
      .def_readwrite("max_range", &PotOptions::max_range, "metres (0: the dictionary's)")
      .def_readwrite("min_samples", &PotOptions::min_samples, "smaller sectors skipped (4)")
      .def_readwrite("max_sample_distance", &PotOptions::max_sample_distance,
                     "metres (0: no limit)")
      .def_readwrite("rotations", &PotOptions::rotations,
                     "radians tried per atom (45 degree steps)")
      .def_readwrite("rank_hits", &PotOptions::rank_hits, "hits a side in the ranking (200)")
      .def_readwrite("rank_free", &PotOptions::rank_free, "free samples a side in the ranking (50)")
      .def_readwrite("rank_epsilon", &PotOptions::rank_epsilon, "scaled metres^2 (0.005)")
      .def_readwrite("rank_max_iterations", &PotOptions::rank_max_iterations, "(1000)")
      .def_readwrite("rank_tolerance", &PotOptions::rank_tolerance, "(1e-7)")
      .def_readwrite("transport_points", &PotOptions::transport_points, "hits a side (1500)")
      .def_readwrite("transport_free_points", &PotOptions::transport_free_points,
                     "free a side (200)")
      .def_readwrite("transport_epsilon", &PotOptions::transport_epsilon,
                     "normalised cost (0.0005)")
      .def_readwrite("transport_max_iterations", &PotOptions::transport_max_iterations, "(2000)")
      .def_readwrite("transport_tolerance", &PotOptions::transport_tolerance, "(1e-5)")
      .def_readwrite("transport_free_tolerance", &PotOptions::transport_free_tolerance,
                     "the free samples' plan's tolerance (1e-2)")
      .def_readwrite("transport_free", &PotOptions::transport_free,
                     "transport free samples too (True)")
      .def_readwrite(
          "wall_clearance", &PotOptions::wall_clearance,
          "barycentric kernels, metres (0.5, about the atoms' kernel spacing; 0: off, the "
          "paper's)")
      .def_readwrite("displacement_variance", &PotOptions::displacement_variance,
                     "weight variance per m^2 moved (0)")
      .def_property(
          "placement",
          [](const PotOptions& o) {
            return o.placement == PotPlacement::target_samples ? "target_samples" : "barycentric";
          },
          [](PotOptions& o, const std::string& v) {
            if (v != "barycentric" && v != "target_samples")
              throw ArgumentError("placement must be 'barycentric' or 'target_samples', not '" + v +
                                  "'");
            o.placement =
                v == "target_samples" ? PotPlacement::target_samples : PotPlacement::barycentric;
          },
          "'target_samples' (default: kernels on the scan's samples, which maps real logs best) "
          "or 'barycentric' (the authors')")
      .def_property(
          "ranking",
          [](const PotOptions& o) {
            return o.ranking == PotRanking::indexed ? "indexed" : "exhaustive";
          },
          [](PotOptions& o, const std::string& v) {
            if (v != "exhaustive" && v != "indexed")
              throw ArgumentError("ranking must be 'exhaustive' or 'indexed', not '" + v + "'");
            o.ranking = v == "indexed" ? PotRanking::indexed : PotRanking::exhaustive;
          },
          "'indexed' (default: the index's nearest atoms at estimated rotations, coarse to "
          "fine; the exhaustive ranking's scores in 3.5 to 9 times less time) or 'exhaustive' "
          "(every atom at every rotation, the paper's)")
      .def_readwrite("anchor_spacing", &PotOptions::anchor_spacing,
                     "target_samples: metres between kernels (0.5)")
      .def_readwrite("anchor_clearance", &PotOptions::anchor_clearance,
                     "target_samples: metres from a hit within which free anchors are dropped "
                     "(0.25, half the atoms' kernel spacing; 0: off)")
      .def_readwrite("anchor_sweeps", &PotOptions::anchor_sweeps,
                     "target_samples: sweeps solving the anchors' weights together, walls and "
                     "free space (10; 0: each class's partition alone)")
      .def_readwrite("logit_gain", &PotOptions::logit_gain,
                     "target_samples: factor on the transported logits (1.5, fitted on the Intel "
                     "log; 1: the atoms' own)")
      .def_readwrite("candidates", &PotOptions::candidates,
                     "atoms pre-selected per sector (0: all)")
      .def_readwrite("refine", &PotOptions::refine, "RePOT (default False: POT)")
      .def_readwrite("refine_bhm", &PotOptions::refine_bhm, "BhmOptions of the refinement")
      .def_readwrite("refine_min_variance", &PotOptions::refine_min_variance, "(1)")
      .def_readwrite("refine_joint", &PotOptions::refine_joint, "joint E-step (True)")
      .def_readwrite("seed", &PotOptions::seed, "subsampling seed (0)");
  add_fields_repr(pot);
}

// OverallMapOptions and MapperOptions: how a Mapper merges and maps.
void bind_pot_mapper_options(py::module_& m) {
  py::class_<OverallMapOptions> oopt(m, "OverallMapOptions", "Merging of POT's overall map.");
  oopt.def(py::init([](const py::kwargs& kw) {
        return options_from<OverallMapOptions>(kw, "OverallMapOptions");
      }))
      .def_readwrite("merge_radius", &OverallMapOptions::merge_radius,
                     "d^2 gamma below which kernels merge (0.25)")
      .def_readwrite("gamma_ratio", &OverallMapOptions::gamma_ratio,
                     "largest width ratio that merges (2)")
      .def_readwrite("max_kernels", &OverallMapOptions::max_kernels, "cap (0: none)")
      .def_readwrite("retire_to", &OverallMapOptions::retire_to,
                     "fraction kept by a retirement (0.9)");
  add_fields_repr(oopt);

  py::class_<MapperOptions> mopt(m, "MapperOptions",
                                 "Settings of a Mapper; the defaults map real logs best (what\n"
                                 "`potmap mapping` runs); MapperOptions.paper(): the authors'.");
  mopt.def(py::init([](const py::kwargs& kw) {
        return options_from<MapperOptions>(kw, "MapperOptions");
      }))
      .def_static("paper", &MapperOptions::paper,
                  "The authors' rules: PotOptions.paper(), average_overall False, RePOT's\n"
                  "seeds barycentric without displacement variance.")
      .def_readwrite("pot", &MapperOptions::pot, "PotOptions (pot.refine: RePOT)")
      .def_property(
          "free_per_metre", [](const MapperOptions& o) { return o.labels.free_per_metre; },
          [](MapperOptions& o, double v) { o.labels.free_per_metre = v; }, "labelling (1)")
      .def_property(
          "holdout", [](const MapperOptions& o) { return o.labels.holdout_fraction; },
          [](MapperOptions& o, double v) { o.labels.holdout_fraction = v; },
          "fraction of each scan's beams held out for scoring (0.2)")
      .def_property(
          "label_seed", [](const MapperOptions& o) { return o.labels.seed; },
          [](MapperOptions& o, std::uint64_t v) { o.labels.seed = v; }, "labelling seed (0)")
      .def_readwrite("persistent_refine", &MapperOptions::persistent_refine,
                     "RePOT keeps one persistent joint BHM (True)")
      .def_readwrite("refine_map", &MapperOptions::refine_map, "JointBhmOptions of that map")
      .def_readwrite("seed_min_variance", &MapperOptions::seed_min_variance, "(10)")
      .def_property(
          "seed_placement",
          [](const MapperOptions& o) {
            return o.seed_placement == PotPlacement::target_samples ? "target_samples"
                                                                    : "barycentric";
          },
          [](MapperOptions& o, const std::string& v) {
            if (v != "barycentric" && v != "target_samples")
              throw ArgumentError(
                  "seed_placement must be 'barycentric' or 'target_samples', not '" + v + "'");
            o.seed_placement =
                v == "target_samples" ? PotPlacement::target_samples : PotPlacement::barycentric;
          },
          "RePOT's persistent map: where its seeds go ('barycentric', default: they reach past "
          "the scan's samples)")
      .def_readwrite("seed_displacement_variance", &MapperOptions::seed_displacement_variance,
                     "RePOT's persistent map: weight variance per m^2 a seed moved (0.25; the "
                     "paper's 0)")
      .def_readwrite("average_overall", &MapperOptions::average_overall,
                     "POT's overall map the support-weighted average of the scans' maps "
                     "(True, which maps real logs; False: summed kernels, the paper's)")
      .def_property(
          "average_spacing", [](const MapperOptions& o) { return o.averaged.spacing; },
          [](MapperOptions& o, double v) { o.averaged.spacing = v; },
          "averaged overall map's grid, metres (0.25)")
      .def_readwrite("async_merge", &MapperOptions::async_merge,
                     "add_scan returns before the scan's merge into the overall map, which "
                     "runs beside the next add_scan; reading the map waits for it (False)")
      .def_readwrite("refine_on_host_team", &MapperOptions::refine_on_host_team,
                     "RePOT's persistent update in two parts on the context's host helper, the "
                     "same map either way (False: slower on a 2-core virtual machine)");
  add_fields_repr(mopt);
}

// transfer_scan() and what it reports.
void bind_pot_transfer(py::module_& m) {
  py::class_<SectorTransfer>(m, "SectorTransfer", "What happened to one target sector.")
      .def_readonly("sector", &SectorTransfer::sector)
      .def_readonly("target_hits", &SectorTransfer::target_hits)
      .def_readonly("target_free", &SectorTransfer::target_free)
      .def_readonly("atom", &SectorTransfer::atom, "chosen atom, -1 if none")
      .def_readonly("rotation", &SectorTransfer::rotation, "radians")
      .def_readonly("score", &SectorTransfer::score, "ranking score (smaller is better)")
      .def_readonly("rank_converged", &SectorTransfer::rank_converged)
      .def_readonly("transport_converged", &SectorTransfer::transport_converged)
      .def_readonly("transport_iterations", &SectorTransfer::transport_iterations)
      .def_readonly("kernels_placed", &SectorTransfer::kernels_placed)
      .def_readonly("kernels_dropped", &SectorTransfer::kernels_dropped);
  py::class_<PotTiming>(m, "PotTiming", "Wall-clock time of each stage of one scan, milliseconds.")
      .def_readonly("prepare_ms", &PotTiming::prepare_ms)
      .def_readonly("ranking_ms", &PotTiming::ranking_ms)
      .def_readonly("transport_ms", &PotTiming::transport_ms)
      .def_readonly("placement_ms", &PotTiming::placement_ms)
      .def_readonly("refine_ms", &PotTiming::refine_ms)
      .def_property_readonly("total_ms", &PotTiming::total_ms);
  py::class_<ScanTransfer>(m, "ScanTransfer",
                           "The instantaneous map of one scan and how it was made.")
      .def_readonly("map", &ScanTransfer::map, "transported kernels, world frame")
      .def_readonly("sectors", &ScanTransfer::sectors, "list of SectorTransfer")
      .def_readonly("timing", &ScanTransfer::timing);
  py::class_<OverallMapAddStats>(m, "OverallMapAddStats", "What one add to the overall map did.")
      .def_readonly("added", &OverallMapAddStats::added)
      .def_readonly("merged", &OverallMapAddStats::merged)
      .def_readonly("retired", &OverallMapAddStats::retired)
      .def_readonly("fused", &OverallMapAddStats::fused);

  m.def(
      "transfer_scan",
      [](Context* ctx, const Dictionary& dict, const LabelledPoints& train,
         const std::vector<double>& sensor, double heading, std::int64_t index,
         py::object options) {
        PotOptions o = options.is_none() ? PotOptions{} : options.cast<PotOptions>();
        std::array<double, 3> s{0, 0, 0};
        if (sensor.size() < 2 || sensor.size() > 3)
          throw py::value_error("sensor: 2 or 3 coordinates");
        std::copy(sensor.begin(), sensor.end(), s.begin());
        py::gil_scoped_release release;
        return transfer_scan(ctx, dict, train, s, heading, index, o);
      },
      "ctx"_a, "dictionary"_a, "train"_a, "sensor"_a, "heading"_a, "index"_a = 0,
      "options"_a = py::none(),
      "Transfers one scan's training samples (LabelledPoints, world frame) seen from sensor\n"
      "(metres) with heading (radians). ctx None: the CPU reference. Returns a ScanTransfer.");
}

// OverallMap, and MappedScan: one scan's instantaneous map and what it did to the
// overall map.
void bind_pot_overall_map(py::module_& m) {
  py::class_<OverallMap>(m, "OverallMap", "POT's overall map: instantaneous maps merged.")
      .def(py::init([](int dim, const py::kwargs& kw) {
             return OverallMap(dim, options_from<OverallMapOptions>(kw, "OverallMap"));
           }),
           "dim"_a = 2, "Keyword arguments: OverallMapOptions fields.")
      .def("add", &OverallMap::add, "instantaneous"_a)  // host work; the GIL keeps adds apart
      .def_property_readonly(
          "map", [](const OverallMap& o) { return o.map(); }, "KernelMap (copy)")
      .def("__len__", &OverallMap::size)
      .def_property_readonly("memory_bytes", &OverallMap::memory_bytes);

  py::class_<ScanStats>(m, "MappedScan", "One mapped scan and what it did to the overall map.")
      .def_property_readonly(
          "index", [](const ScanStats& s) { return s.scan.index; }, "scan number")
      .def_property_readonly(
          "map", [](const ScanStats& s) { return s.scan.transfer.map; },
          "the instantaneous map (transported kernels, world frame)")
      .def_property_readonly("sectors", [](const ScanStats& s) { return s.scan.transfer.sectors; })
      .def_property_readonly("timing", [](const ScanStats& s) { return s.scan.transfer.timing; })
      .def_property_readonly(
          "test", [](const ScanStats& s) { return s.scan.test; },
          "held-out samples within the sector radius (LabelledPoints)")
      .def_property_readonly("train", [](const ScanStats& s) { return s.scan.train; })
      .def_property_readonly("wall_ms", [](const ScanStats& s) { return s.scan.wall_ms; })
      .def_property_readonly(
          "merge", [](const ScanStats& s) { return s.merge.stats; }, "OverallMapAddStats (POT)")
      .def_property_readonly(
          "seeded", [](const ScanStats& s) { return s.merge.seeded; },
          "persistent-map kernels seeded (RePOT)")
      .def_property_readonly("merge_ms", [](const ScanStats& s) { return s.merge.merge_ms; })
      .def("__repr__", [](const ScanStats& s) {
        return "<potmap.MappedScan " + std::to_string(s.scan.index) + ": " +
               std::to_string(s.scan.transfer.map.size()) + " kernels, " +
               std::to_string(s.scan.transfer.timing.total_ms()) + " ms>";
      });
}

// The Mapper, under its lock.
void bind_pot_mapper(py::module_& m) {
  py::class_<LockedMapper>(
      m, "Mapper",
      "Incremental POT / RePOT mapping: add_scan() maps one scan and adds it to the\n"
      "overall map. Keeps its Context and Dictionary alive.")
      .def(py::init([](Context* ctx, std::shared_ptr<Dictionary> dict, bool refine,
                       py::object options, py::object overall) {
             MapperOptions o = options.is_none() ? MapperOptions{} : options.cast<MapperOptions>();
             if (refine) o.pot.refine = true;
             OverallMapOptions ov =
                 overall.is_none() ? OverallMapOptions{} : overall.cast<OverallMapOptions>();
             return std::make_unique<LockedMapper>(ctx, std::move(dict), o, ov);
           }),
           "ctx"_a, "dictionary"_a, "refine"_a = false, "options"_a = py::none(),
           "overall"_a = py::none(), py::keep_alive<1, 2>(),
           "ctx: the device (None: the CPU reference, slow); dictionary: a Dictionary;\n"
           "refine: RePOT (default False: POT; same as options.pot.refine = True); options:\n"
           "MapperOptions (default: the library's, which map real logs best, as `potmap\n"
           "mapping`: 20 % of beams held out, 5 sectors, 8 rotations, indexed ranking, ...;\n"
           "MapperOptions.paper() for the authors' rules);\n"
           "overall: OverallMapOptions of POT's summed map (default merge_radius 0.25).")
      .def(
          "add_scan",
          [](LockedMapper& lm, const Scan& scan) {
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(lm.mu);
            const MappedScan& r = lm.mapper.add_scan(scan);
            // With async_merge the scan's merge is still running: waiting for its counts here
            // would undo the option.
            return ScanStats{
                r, lm.mapper.options().async_merge ? MapperMerge{} : lm.mapper.last_merge()};
          },
          "scan"_a,
          "Maps one Scan (labelled with its index = scans added so far) and adds it to the\n"
          "overall map. Returns its MappedScan: instantaneous map, sector choices, timings,\n"
          "held-out samples, merge counts (zero with options.async_merge: the merge is then\n"
          "still running).")
      .def(
          "overall_map",
          [](LockedMapper& lm) {
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(lm.mu);
            return lm.mapper.overall_map();
          },
          "The overall KernelMap (POT: merged; RePOT: the persistent BHM's export, with a bias).")
      .def(
          "save_overall_map",
          [](LockedMapper& lm, const std::string& path) {
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(lm.mu);
            write_mapper_map(lm.mapper, path);
          },
          "path"_a,
          "Writes the overall map (format by extension). Into a .potmap, RePOT's persistent map\n"
          "carries its information form and POT's averaged map its anchor sums, for\n"
          "merge_maps(); other maps are the map alone.")
      .def_property_readonly("overall_kernels", locked(&Mapper::overall_kernels))
      .def_property_readonly("overall_memory_bytes", locked(&Mapper::overall_memory_bytes))
      .def_property_readonly("scans", locked(&Mapper::scans),
                             "scans added since construction or reset()")
      .def_property_readonly("options", locked(&Mapper::options), "MapperOptions (a copy)")
      .def(
          "reset",
          [](LockedMapper& lm) {
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(lm.mu);
            lm.mapper.reset();
          },
          "Forgets every scan (same options).")
      .def(
          "save_state",
          [](LockedMapper& lm, const std::string& path) {
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(lm.mu);
            lm.mapper.save_state(path);
          },
          "path"_a,
          "Writes the whole state (overall map, RePOT's persistent learner, scan count) to\n"
          "path, through a temporary file renamed into place: load_state() into a Mapper\n"
          "with the same dictionary and options continues exactly (the same overall map,\n"
          "bit for bit). The last scan's MappedScan is not saved.")
      .def(
          "load_state",
          [](LockedMapper& lm, const std::string& path) {
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(lm.mu);
            lm.mapper.load_state(path);
          },
          "path"_a,
          "Restores a state written by save_state(). InputError (naming the file) for a\n"
          "missing, truncated or corrupt file, or a state of another dictionary or other\n"
          "options; the mapper is unchanged then.");
}

}  // namespace

void bind_pot(py::module_& m) {
  bind_pot_sectors(m);
  bind_pot_dictionary(m);
  bind_pot_options(m);
  bind_pot_mapper_options(m);
  bind_pot_transfer(m);
  bind_pot_overall_map(m);
  bind_pot_mapper(m);
}

}  // namespace potmap::python
