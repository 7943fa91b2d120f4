// 3D drives: the drive index, a keyframe at a time, and the joint BHM's drive mapper
// (include/potmap/data/drive.hpp, include/potmap/mapping/drive_mapper.hpp).

#include <pybind11/stl.h>

#include <cctype>
#include <filesystem>

#include <memory>
#include <mutex>

#include "bindings.hpp"
#include "convert.hpp"
#include "potmap/data/drive.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/learn/bhm_joint_merge.hpp"
#include "potmap/mapping/drive_mapper.hpp"
#include "potmap/mapping/drive_volume.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap::python {

namespace py = pybind11;
using namespace pybind11::literals;

namespace {

// The mapper with a lock: calls release the GIL, so two Python threads must not update it at
// once.
struct PyDriveMapper {
  explicit PyDriveMapper(const DriveMapperOptions& o) : m(o) {}
  DriveMapper m;
  std::unique_ptr<std::mutex> mu = std::make_unique<std::mutex>();
};

py::array_t<double> poses_array(const Drive& d) {
  py::array_t<double> a({static_cast<py::ssize_t>(d.size()), py::ssize_t(3), py::ssize_t(4)});
  double* p = a.mutable_data();
  for (const auto& pose : d.poses) p = std::copy(pose.begin(), pose.end(), p);
  return a;
}

void bind_drive(py::module_& m) {
  py::class_<Drive>(m, "Drive",
                    "The index of a 3D drive (SLAM keyframes or a KITTI sequence): names, poses\n"
                    "and times; keyframes are read one at a time with keyframe(i).")
      .def_readonly("path", &Drive::path)
      .def_readonly("layout", &Drive::layout, "'slam', 'kitti' or 'rosbag'")
      .def_readonly("poses_file", &Drive::poses_file)
      .def_readonly("frames", &Drive::frames, "keyframe files, in order")
      .def_readonly("times", &Drive::times, "seconds (keyframe indices without times.txt)")
      .def_readonly("max_range", &Drive::max_range, "metres")
      .def_property_readonly("poses", &poses_array, "(n, 3, 4) sensor-to-world [R | t]")
      .def("__len__", &Drive::size)
      .def(
          "keyframe", [](const Drive& d, std::size_t i) { return read_keyframe(d, i); }, "i"_a,
          py::call_guard<py::gil_scoped_release>(),
          "Keyframe i as a 3D Scan in the world frame (read now).");
  m.def(
      "open_drive",
      [](const std::string& path, const std::string& poses, double max_range,
         const BagOptions& bag) {
        DriveOptions o;
        o.poses = poses;
        o.max_range = max_range;
        o.bag = bag;
        return open_drive(path, o);
      },
      "path"_a, "poses"_a = "odom", "max_range"_a = 120.0, "bag"_a = BagOptions{},
      py::call_guard<py::gil_scoped_release>(),
      "Indexes a drive folder, or a ROS bag's point-cloud topic (bag: BagOptions). poses:\n"
      "'odom' (odom_poses.txt, default), 'optimized' or 'auto'. max_range: the sensor's\n"
      "range, metres (default 120). Errors name the file, line and value (InputError).");
}

// DriveMapperOptions and KeyframeStats: what a DriveMapper is made with and reports.
void bind_drive_options(py::module_& m) {
  py::class_<DriveMapperOptions> opt(m, "DriveMapperOptions",
                                     "How a 3D drive is mapped; the defaults are `potmap "
                                     "mapping DRIVE`'s (docs/drives-3d.md).");
  opt.def(py::init([](const py::kwargs& kw) {
       return options_from<DriveMapperOptions>(kw, "DriveMapperOptions");
     }))
      .def_readwrite("range_cut", &DriveMapperOptions::range_cut,
                     "horizontal range cut, metres (default 40)")
      .def_property(
          "free_per_metre", [](const DriveMapperOptions& o) { return o.labels.free_per_metre; },
          [](DriveMapperOptions& o, double v) { o.labels.free_per_metre = v; },
          "free samples per metre of beam (default 0.5)")
      .def_property(
          "holdout_fraction", [](const DriveMapperOptions& o) { return o.labels.holdout_fraction; },
          [](DriveMapperOptions& o, double v) { o.labels.holdout_fraction = v; },
          "beams of each keyframe held out for scoring (default 0.2)")
      .def_property(
          "seed", [](const DriveMapperOptions& o) { return o.labels.seed; },
          [](DriveMapperOptions& o, std::uint64_t v) { o.labels.seed = v; },
          "labelling seed (default 0)")
      .def_readwrite("voxel", &DriveMapperOptions::voxel,
                     "samples gathered per voxel of this edge, metres (default 0.5; 0: none)")
      .def_readwrite("bhm", &DriveMapperOptions::bhm,
                     "the JointBhmOptions (default: the drive defaults, 1 m kernels)")
      .def_readwrite("retire_radius", &DriveMapperOptions::retire_radius,
                     "tiles farther than this from the sensor are retired, metres (default -1: "
                     "range_cut + 16; 0: never)")
      .def_readwrite("test_stride", &DriveMapperOptions::test_stride,
                     "every this many held-out samples one is kept (default 4)")
      .def_readwrite("lookahead", &DriveMapperOptions::lookahead,
                     "score each keyframe's kept held-out samples on the map before it is "
                     "added (default False; DriveMapper.lookahead)")
      .def_property(
          "dictionary",
          [](const DriveMapperOptions& o) {
            return std::const_pointer_cast<Dictionary>(o.dictionary);
          },
          [](DriveMapperOptions& o, std::shared_ptr<Dictionary> d) { o.dictionary = std::move(d); },
          "RePOT: a 3D Dictionary whose transport seeds the joint BHM where no sample reaches "
          "(default None: the joint BHM alone)")
      .def_readwrite("seed_min_variance", &DriveMapperOptions::seed_min_variance,
                     "RePOT: seeded prior variances are at least this (default 10)")
      .def_readwrite("transfer_every", &DriveMapperOptions::transfer_every,
                     "RePOT: transfer every this many keyframes (default 4)");
  add_fields_repr(opt);

  py::class_<KeyframeStats>(m, "KeyframeStats", "What DriveMapper.add() did.")
      .def_readonly("samples", &KeyframeStats::samples, "training samples before gathering")
      .def_readonly("gathered", &KeyframeStats::gathered, "weighted samples learned")
      .def_readonly("held_out", &KeyframeStats::held_out, "held-out samples kept")
      .def_readonly("lookahead_ms", &KeyframeStats::lookahead_ms, "the look-ahead's scoring")
      .def_readonly("retired", &KeyframeStats::retired, "tiles retired")
      .def_readonly("label_ms", &KeyframeStats::label_ms, "cut, labelling, gathering")
      .def_readonly("update_ms", &KeyframeStats::update_ms, "update and retiring")
      .def_readonly("transfer_ms", &KeyframeStats::transfer_ms, "RePOT's transfer and seeding")
      .def_readonly("seeded", &KeyframeStats::seeded, "kernels RePOT seeded")
      .def_readonly("on_device", &KeyframeStats::on_device, "samples gathered on the device")
      .def_readonly("sums_on_device", &KeyframeStats::sums_on_device,
                    "the learner's features and sums ran on the device")
      .def_readonly("memory_bytes", &KeyframeStats::memory_bytes, "held after it");
}

// What export_drive_volume returns, as a dict (the band as (ny, nx) arrays, -1: unknown).
py::dict volume_dict(const DriveVolume& v) {
  const HeightBandRaster& b = v.band;
  const std::vector<py::ssize_t> shape = {py::ssize_t(b.ny), py::ssize_t(b.nx)};
  return py::dict("voxel"_a = v.voxel, "blocks"_a = v.blocks, "occupied"_a = v.occupied,
                  "free"_a = v.free, "unknown"_a = v.unknown, "octomap_nodes"_a = v.octomap_nodes,
                  "octomap_leaves"_a = v.octomap_leaves,
                  "band_origin"_a = py::make_tuple(b.origin[0], b.origin[1]), "band_res"_a = b.res,
                  "band_prob"_a = to_array(b.prob, shape), "band_var"_a = to_array(b.var, shape));
}

void bind_drive_volume(py::module_& m) {
  m.def(
      "export_drive_volume",
      [](Context& ctx, const KernelMap& map, const std::vector<double>& path,
         const std::string& octomap, const std::string& cloud, double voxel, double band_low,
         double band_high, py::object progress) {
        DriveVolumeOptions o;
        o.octomap_path = octomap;
        o.cloud_path = cloud;
        o.voxel = voxel;
        o.band_low = band_low;
        o.band_high = band_high;
        if (!progress.is_none())
          o.progress = [progress](double f) {  // an exception from it stops the export
            py::gil_scoped_acquire acquire;
            progress(f);
          };
        DriveVolume v;
        {
          py::gil_scoped_release release;
          v = export_drive_volume(ctx, map, path, o);
        }
        return volume_dict(v);
      },
      "ctx"_a, "map"_a, "path"_a, "octomap"_a = "", "cloud"_a = "", "voxel"_a = 0.4,
      "band_low"_a = -1.0, "band_high"_a = 0.5, "progress"_a = py::none(),
      "A 3D map's volume, evaluated on the device over the blocks holding its kernels, as the\n"
      "files `potmap mapping DRIVE` writes: octomap: a .bt of every known voxel; cloud: a .ply\n"
      "of the occupied voxels (empty: not written). path: the sensor's positions in order\n"
      "(x, y, z, ...), whose height the band follows; voxel, band_low, band_high in metres;\n"
      "progress(fraction) after each batch (raise to stop: nothing is written). Call it on\n"
      "DriveMapper.map() between keyframes for the map so far. Returns a dict: voxel counts,\n"
      "the OctoMap's nodes and leaves, and the band (band_prob, band_var: (ny, nx) arrays from\n"
      "band_origin at band_res metres; band_prob -1 where nothing of the band is known).");
}

}  // namespace

void bind_drives(py::module_& m) {
  bind_drive(m);
  bind_drive_volume(m);
  bind_drive_options(m);
  py::class_<PyDriveMapper>(m, "DriveMapper",
                            "The joint BHM over a 3D drive, a keyframe at a time, in memory that\n"
                            "follows the place (tiles the sensor left are retired).")
      .def(py::init([](const py::kwargs& kw) {
             return PyDriveMapper(options_from<DriveMapperOptions>(kw, "DriveMapper"));
           }),
           "Keyword arguments: DriveMapperOptions fields (range_cut=40 m, voxel=0.5 m, ...).")
      .def(
          "add",
          [](PyDriveMapper& d, const Scan& s, std::int64_t index, Context* ctx) {
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(*d.mu);
            return d.m.add(s, index, ctx);
          },
          "keyframe"_a, "index"_a, "ctx"_a = nullptr,
          "Adds a 3D Scan (world frame) as keyframe `index` (which seeds its labelling).")
      .def(
          "map",
          [](PyDriveMapper& d, Context* ctx) {
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(*d.mu);
            return d.m.map(ctx);
          },
          "ctx"_a = nullptr,
          "The KernelMap of every keyframe so far (retired tiles included); with ctx its\n"
          "polishing solve runs on the context's host team (the same map).")
      .def(
          "save_map",
          [](PyDriveMapper& d, const std::string& path) {
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(*d.mu);
            std::string ext = std::filesystem::path(path).extension().string();
            for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
            // A retired tile's couplings went into its neighbours' eta: no exact form then.
            if (d.m.learner().retired_tiles() == 0 && ext == ".potmap")
              write_joint_bhm_map(d.m.learner(), path);
            else
              write_map(d.m.map(), path);
          },
          "path"_a,
          "Writes the map (format by extension). Into a .potmap with no tile retired\n"
          "(retire_radius 0) the joint BHM's information form goes with it, for merge_maps().")
      .def_property_readonly(
          "held_out",
          [](PyDriveMapper& d) {
            std::lock_guard<std::mutex> lock(*d.mu);
            return d.m.held_out();
          },
          "the held-out samples kept (LabelledPoints)")
      .def_property_readonly(
          "lookahead",
          [](PyDriveMapper& d) {
            std::lock_guard<std::mutex> lock(*d.mu);
            const LookAhead& la = d.m.lookahead();
            py::array_t<float> prob(py::ssize_t(la.size()));
            py::array_t<std::uint8_t> label(py::ssize_t(la.size())), beyond(py::ssize_t(la.size()));
            std::copy(la.prob.begin(), la.prob.end(), prob.mutable_data());
            std::copy(la.label.begin(), la.label.end(), label.mutable_data());
            std::copy(la.beyond.begin(), la.beyond.end(), beyond.mutable_data());
            return py::make_tuple(prob, label, beyond);
          },
          "(prob, label, beyond) arrays of the look-ahead (options lookahead): per kept\n"
          "held-out sample of every keyframe after the first, the map's probability before\n"
          "the keyframe was added, its label, and 1 where no earlier sample had reached it")
      .def_property_readonly("keyframes", [](PyDriveMapper& d) { return d.m.keyframes(); })
      .def_property_readonly("memory_bytes", [](PyDriveMapper& d) { return d.m.memory_bytes(); })
      .def(
          "save_state",
          [](PyDriveMapper& d, const std::string& path) {
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(*d.mu);
            d.m.save_state(path);
          },
          "path"_a, "Writes the whole state atomically; load_state() continues bit for bit.")
      .def(
          "load_state",
          [](PyDriveMapper& d, const std::string& path) {
            py::gil_scoped_release release;
            std::lock_guard<std::mutex> lock(*d.mu);
            d.m.load_state(path);
          },
          "path"_a, "Restores a state saved with the same options.");

  m.def(
      "map_drive",
      [](const std::string& path, std::size_t first, std::size_t count, Context* ctx,
         const py::kwargs& kw) {
        const DriveMapperOptions o = options_from<DriveMapperOptions>(kw, "map_drive");
        py::gil_scoped_release release;
        const Drive d = open_drive(path);
        PyDriveMapper m(o);
        const std::size_t end = count ? std::min(d.size(), first + count) : d.size();
        for (std::size_t i = first; i < end; ++i)
          m.m.add(read_keyframe(d, i), std::int64_t(i), ctx);
        return m;
      },
      "path"_a, "first"_a = 0, "count"_a = 0, "ctx"_a = nullptr,
      "Maps a drive folder in one call (count 0: to the end) and returns its DriveMapper\n"
      "(map(), held_out). Keyword arguments: DriveMapperOptions fields.");
}

}  // namespace potmap::python
