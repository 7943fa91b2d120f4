// Scans, dataset readers, labelling and the town simulator (include/potmap/data/).

#include <pybind11/stl.h>

#include "bindings.hpp"
#include "convert.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/data/simulator.hpp"

namespace potmap::python {

namespace py = pybind11;
using namespace pybind11::literals;

namespace {

LabelledPoints make_points(py::handle positions, py::handle labels, py::object scan) {
  Points p = points_arg(positions, 0, "positions");
  LabelledPoints out;
  out.dim = static_cast<int>(p.array.shape(1));
  out.position.assign(p.data, p.data + p.n * out.dim);
  out.label = labels_arg(labels, static_cast<long>(p.n), "labels");
  if (scan.is_none()) {
    out.scan.assign(p.n, 0);
  } else {
    auto s = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(scan);
    if (!s || s.ndim() != 1 || static_cast<std::size_t>(s.shape(0)) != p.n) {
      throw py::value_error("scan: expected an integer array of shape (" + std::to_string(p.n) +
                            ",)");
    }
    out.scan.assign(s.data(), s.data() + p.n);
  }
  return out;
}

std::array<double, 12> pose3d_arg(py::handle obj) {
  auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj);
  if (!a || a.size() != 12 ||
      !((a.ndim() == 2 && a.shape(0) == 3 && a.shape(1) == 4) || a.ndim() == 1)) {
    throw py::value_error("pose: a 3D pose is a (3, 4) array [R | t]");
  }
  std::array<double, 12> out;
  std::copy(a.data(), a.data() + 12, out.begin());
  return out;
}

Scan make_scan(py::handle hits, py::object no_return, py::object pose, double max_range,
               double timestamp) {
  Points h = points_arg(hits, 0, "hits");
  Scan s;
  s.dim = static_cast<int>(h.array.shape(1));
  s.hits.assign(h.data, h.data + h.n * s.dim);
  if (!no_return.is_none()) {
    Points d = points_arg(no_return, s.dim, "no_return");
    s.no_return.assign(d.data, d.data + d.n * s.dim);
  }
  if (!pose.is_none()) {
    if (s.dim == 2) {
      s.pose2d = pose.cast<std::array<double, 3>>();
    } else {
      s.pose3d = pose3d_arg(pose);
    }
  }
  if (!(max_range > 0)) throw py::value_error("max_range: must be > 0 metres");
  s.max_range = max_range;
  s.timestamp = timestamp;
  return s;
}

LabelOptions label_options(double free_per_metre, double holdout, std::uint64_t seed,
                           long max_free_per_beam) {
  LabelOptions o;
  o.free_per_metre = free_per_metre;
  o.holdout_fraction = holdout;
  o.seed = seed;
  o.max_free_per_beam = max_free_per_beam;
  return o;
}

using release = py::call_guard<py::gil_scoped_release>;

// LabelledPoints and Scan.
void bind_data_scans(py::module_& m) {
  py::class_<LabelledPoints>(m, "LabelledPoints",
                             "Positions with an occupancy label (1 = hit, 0 = free) and the scan\n"
                             "index each came from. Array properties return copies.")
      .def(py::init(&make_points), "positions"_a, "labels"_a, "scan"_a = py::none(),
           "positions: (n, 2) or (n, 3) metres; labels: (n,) 0/1 (bool or integer);\n"
           "scan: (n,) integer scan index of each point (default all 0).")
      .def_readonly("dim", &LabelledPoints::dim)
      .def("__len__", &LabelledPoints::size)
      .def_property_readonly(
          "positions", [](const LabelledPoints& p) { return points_array(p.position, p.dim); },
          "(n, dim) float64, metres")
      .def_property_readonly(
          "labels",
          [](const LabelledPoints& p) {
            return to_array(p.label, {static_cast<py::ssize_t>(p.size())});
          },
          "(n,) uint8, 1 occupied")
      .def_property_readonly(
          "scan",
          [](const LabelledPoints& p) {
            return to_array(p.scan, {static_cast<py::ssize_t>(p.scan.size())});
          },
          "(n,) int64 scan index");

  py::class_<Scan>(m, "Scan",
                   "One LIDAR sweep in the world frame: hit end points and the unit directions\n"
                   "of beams without a return. Array properties return copies.")
      .def(py::init(&make_scan), "hits"_a, "no_return"_a = py::none(), "pose"_a = py::none(),
           "max_range"_a = 20.0, "timestamp"_a = 0.0,
           "hits: (n, 2) or (n, 3) beam end points, world frame, metres; no_return: (k, dim)\n"
           "unit directions of beams that returned nothing (default none); pose: 2D (x, y, yaw)\n"
           "in metres and radians, 3D a (3, 4) [R | t] (default: the origin); max_range:\n"
           "metres (default 20); timestamp: seconds (default 0).")
      .def_readonly("dim", &Scan::dim)
      .def_readonly("timestamp", &Scan::timestamp, "seconds")
      .def_readonly("max_range", &Scan::max_range, "metres")
      .def_property_readonly("hits", [](const Scan& s) { return points_array(s.hits, s.dim); })
      .def_property_readonly("no_return",
                             [](const Scan& s) { return points_array(s.no_return, s.dim); })
      .def_property_readonly(
          "pose",
          [](const Scan& s) -> py::object {
            if (s.dim == 2) return py::make_tuple(s.pose2d[0], s.pose2d[1], s.pose2d[2]);
            std::vector<double> v(s.pose3d.begin(), s.pose3d.end());
            return to_array(v, {3, 4});
          },
          "2D: (x, y, yaw); 3D: (3, 4) [R | t]")
      .def_property_readonly(
          "origin",
          [](const Scan& s) {
            auto o = s.origin();
            return std::vector<double>(o.begin(), o.begin() + s.dim);
          },
          "sensor position, world frame, metres")
      .def_property_readonly("num_beams", &Scan::num_beams)
      .def("__repr__", [](const Scan& s) {
        return "<potmap.Scan " + std::to_string(s.dim) + "D, " + std::to_string(s.num_hits()) +
               " hits, " + std::to_string(s.num_no_return()) + " no-returns>";
      });
}

// The dataset readers and what they return.
void bind_data_readers(py::module_& m) {
  py::class_<ReadStats>(m, "ReadStats", "What a reader saw besides the scans.")
      .def_readonly("lines_skipped", &ReadStats::lines_skipped)
      .def_readonly("points_dropped", &ReadStats::points_dropped, "NaN or Inf points dropped");
  py::class_<Dataset>(m, "Dataset", "Scans read from a file, and the reader's counts.")
      .def_readonly("scans", &Dataset::scans, "list of Scan")
      .def_readonly("stats", &Dataset::stats)
      .def("__len__", [](const Dataset& d) { return d.scans.size(); })
      .def("__getitem__", [](const Dataset& d, long i) {
        long n = static_cast<long>(d.scans.size());
        if (i < 0) i += n;
        if (i < 0 || i >= n) throw py::index_error("scan index out of range");
        return d.scans[static_cast<std::size_t>(i)];
      });

  m.def("read_dataset", &read_dataset, "path"_a, "bag"_a = BagOptions{}, release(),
        "Reads any supported file by its name: *.log[.gz] CARMEN, *.bin KITTI or nuScenes,\n"
        "a KITTI odometry poses.txt, *.npz and *.csv labelled samples, ROS 1 .bag files and\n"
        "ROS 2 bag folders (bag: BagOptions, the topic, frame and poses). InputError names\n"
        "the file, line or offset and value.");
  m.def("read_carmen", &read_carmen, "path"_a, "flaser_max_range"_a = 0.0,
        "flaser_fov"_a = 3.14159265358979323846, release(),
        "CARMEN log (plain or gzip). flaser_max_range: metres (default 0: the largest range in\n"
        "the file); flaser_fov: radians (default pi).");
  m.def("read_kitti_bin", &read_kitti_bin, "path"_a, "max_range"_a = 120.0, release(),
        "KITTI Velodyne frame (N x 4 float32), sensor at the origin; max_range metres (120).");
  m.def("read_nuscenes_bin", &read_nuscenes_bin, "path"_a, "max_range"_a = 110.0, release(),
        "nuScenes LIDAR_TOP frame (N x 5 float32); max_range metres (default 110).");
  m.def(
      "read_kitti_poses",
      [](const std::string& poses, const std::string& calib) {
        auto v = read_kitti_poses(poses, calib);
        py::array_t<double> out(
            {static_cast<py::ssize_t>(v.size()), py::ssize_t(3), py::ssize_t(4)});
        for (std::size_t i = 0; i < v.size(); ++i)
          std::copy(v[i].begin(), v[i].end(), out.mutable_data() + 12 * i);
        return out;
      },
      "poses_path"_a, "calib_path"_a,
      "Velodyne-to-world poses of a KITTI odometry sequence: (frames, 3, 4) float64.");
  m.def("read_npz_labelled", &read_npz_labelled, "path"_a, release(),
        "Labelled samples from an .npz with X (t, x, y[, z]) and Y (labels).");
  m.def("scans_from_labelled", &scans_from_labelled, "points"_a, "max_range"_a = 20.0, release(),
        "Groups labelled points into scans by their scan index (hits only become beams).");
  m.def("slice_2d", &slice_2d, "scan"_a, "z_min"_a = -0.1, "z_max"_a = 0.1,
        "The 2D slice of a 3D scan: points whose height above the sensor is in [z_min, z_max]\n"
        "metres (default +-0.1), projected on the ground plane.");
}

// Labelling and the train / held-out split of scans.
void bind_data_labelling(py::module_& m) {
  py::class_<LabelledSplit>(m, "LabelledSplit", "Training and held-out samples of scans.")
      .def_readonly("train", &LabelledSplit::train, "LabelledPoints of the kept beams")
      .def_readonly("test", &LabelledSplit::test, "LabelledPoints of the held-out beams")
      .def_readonly("points_dropped", &LabelledSplit::points_dropped,
                    "NaN or Inf end points skipped")
      .def("__iter__",
           [](const LabelledSplit& s) { return py::iter(py::make_tuple(s.train, s.test)); });

  m.def(
      "label",
      [](py::object scans, double free_per_metre, double holdout, std::uint64_t seed,
         long max_free_per_beam) {
        std::vector<Scan> v = py::isinstance<Dataset>(scans) ? scans.cast<const Dataset&>().scans
                                                             : scans.cast<std::vector<Scan>>();
        LabelOptions o = label_options(free_per_metre, holdout, seed, max_free_per_beam);
        py::gil_scoped_release release;
        return label_scans(v, o);
      },
      "scans"_a, "free_per_metre"_a = 1.0, "holdout"_a = 0.2, "seed"_a = 0,
      "max_free_per_beam"_a = 10000,
      "Labelled samples of scans (a list of Scan or a Dataset; scan index = position), SPEC\n"
      "section 1: every hit is a 1; free samples (0) lie on each beam, free_per_metre per metre\n"
      "of free beam (default 1, at least one a beam, at most max_free_per_beam); a seeded\n"
      "fraction holdout of each scan's beams (default 0.2) goes with all its samples to test.\n"
      "Returns a LabelledSplit (train, test = potmap.label(...)). Same seed, same samples.");
  m.def(
      "label_scan",
      [](const Scan& scan, std::int64_t index, double free_per_metre, double holdout,
         std::uint64_t seed) {
        LabelledSplit out;
        py::gil_scoped_release release;
        label_scan(scan, index, label_options(free_per_metre, holdout, seed, 10000), out);
        return out;
      },
      "scan"_a, "index"_a = 0, "free_per_metre"_a = 1.0, "holdout"_a = 0.2, "seed"_a = 0,
      "label() of one scan with scan index `index` (which seeds its samples and split).");
  m.def(
      "split_beams",
      [](const Scan& scan, std::int64_t index, double holdout, std::uint64_t seed, bool held_out) {
        return split_beams(scan, index, label_options(1.0, holdout, seed, 10000), held_out);
      },
      "scan"_a, "index"_a = 0, "holdout"_a = 0.2, "seed"_a = 0, "held_out"_a = false,
      "The scan with only its training beams (or, held_out=True, only its held-out beams)\n"
      "under label()'s split.");
}

// The town simulator.
void bind_data_simulator(py::module_& m) {
  py::class_<Town>(m, "Town", "A procedural town for the LIDAR simulator (metres).")
      .def_static("builtin", &Town::builtin, "name"_a, "seed"_a = 0,
                  "'town1' (regular terraces), 'town2' (large L-shaped blocks, leafy) or 'town3'\n"
                  "(dense rotated houses). ArgumentError for other names.")
      .def_property_readonly("name", &Town::name)
      .def_property_readonly("width", &Town::width, "metres, x from 0")
      .def_property_readonly("height", &Town::height, "metres, y from 0")
      .def(
          "occupied",
          [](const Town& t, py::handle points) {
            Points p = points_arg(points, 0, "points");
            int d = static_cast<int>(p.array.shape(1));
            py::array_t<bool> out(static_cast<py::ssize_t>(p.n));
            for (std::size_t i = 0; i < p.n; ++i) {
              const double* x = p.data + i * d;
              out.mutable_data()[i] =
                  d == 2 ? t.occupied(x[0], x[1]) : t.occupied(x[0], x[1], x[2]);
            }
            return out;
          },
          "points"_a, "Ground truth at (n, 2) or (n, 3) points: inside an obstacle (bool array).");

  py::class_<Simulation>(m, "Simulation", "Simulated scans along a route.")
      .def_readonly("scans", &Simulation::scans, "list of Scan")
      .def_property_readonly(
          "route", [](const Simulation& s) { return points_array(s.route, 2); },
          "(scans, 2) sensor x, y, metres");
  m.def(
      "simulate",
      [](const Town& town, std::size_t scans, double spacing, double max_range, double step_deg,
         bool three_d, int moving_vehicles, std::uint64_t seed) {
        SimOptions o;
        o.scans = scans;
        o.spacing = spacing;
        o.max_range = max_range;
        o.step_deg = step_deg;
        o.three_d = three_d;
        o.moving_vehicles = moving_vehicles;
        o.seed = seed;
        py::gil_scoped_release release;
        return simulate(town, o);
      },
      "town"_a, "scans"_a = 100, "spacing"_a = 1.0, "max_range"_a = 20.0, "step_deg"_a = 1.0,
      "three_d"_a = false, "moving_vehicles"_a = 0, "seed"_a = 0,
      "Drives a seeded route through town and scans at every stop: scans (default 100),\n"
      "spacing metres between scans (1), max_range metres (20), step_deg degrees between\n"
      "beams (1), three_d for a 16-ring sensor, moving_vehicles other cars, seed the route.");
}

}  // namespace

void bind_data(py::module_& m) {
  bind_data_scans(m);
  bind_bags(m);  // before the readers: read_dataset's default BagOptions needs its type
  bind_data_readers(m);
  bind_data_labelling(m);
  bind_data_simulator(m);
}

}  // namespace potmap::python
