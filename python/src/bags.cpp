// ROS bags: the options that pick topic, frame and poses, the summary `potmap data info`
// prints, and the readers (include/potmap/data/bag.hpp).

#include <pybind11/stl.h>

#include "bindings.hpp"
#include "convert.hpp"
#include "potmap/data/bag.hpp"

namespace potmap::python {

namespace py = pybind11;
using namespace pybind11::literals;

void bind_bags(py::module_& m) {
  py::class_<BagOptions> opt(m, "BagOptions",
                             "How a ROS bag is read: the topic, the fixed frame, the poses and "
                             "the keyframe spacing of point clouds.");
  opt.def(py::init([](const py::kwargs& kw) { return options_from<BagOptions>(kw, "BagOptions"); }))
      .def_readwrite("topic", &BagOptions::topic,
                     "LaserScan, MultiEchoLaserScan or PointCloud2 topic ('': the one with the "
                     "most messages)")
      .def_readwrite("fixed_frame", &BagOptions::fixed_frame,
                     "frame to map in ('': map when /tf links it to the sensor, else odom)")
      .def_readwrite("pose_topic", &BagOptions::pose_topic,
                     "nav_msgs/Odometry or geometry_msgs/PoseStamped topic ('': /tf)")
      .def_readwrite("max_range", &BagOptions::max_range,
                     "metres (0: a LaserScan's range_max; 120 for point clouds)")
      .def_readwrite("keyframe_distance", &BagOptions::keyframe_distance,
                     "point clouds: metres between keyframes (default 1)")
      .def_readwrite("keyframe_angle", &BagOptions::keyframe_angle,
                     "point clouds: radians of turn that start a keyframe (default 0.26)");
  add_fields_repr(opt);

  py::class_<BagTopicSummary>(m, "BagTopicSummary", "One topic of a bag.")
      .def_readonly("name", &BagTopicSummary::name)
      .def_readonly("type", &BagTopicSummary::type, "ROS 1 spelling: 'sensor_msgs/LaserScan'")
      .def_readonly("count", &BagTopicSummary::count, "messages")
      .def_readonly("frame_id", &BagTopicSummary::frame_id, "of its first message");
  py::class_<BagSummary>(m, "BagSummary", "A bag's topics and what would be mapped.")
      .def_readonly("format", &BagSummary::format)
      .def_readonly("compression", &BagSummary::compression)
      .def_readonly("topics", &BagSummary::topics)
      .def_readonly("start", &BagSummary::start, "seconds")
      .def_readonly("duration", &BagSummary::duration, "seconds")
      .def_readonly("topic", &BagSummary::topic, "the topic that would be mapped")
      .def_readonly("type", &BagSummary::type)
      .def_readonly("dim", &BagSummary::dim, "2 (laser scans) or 3 (point clouds)")
      .def_readonly("pose_source", &BagSummary::pose_source)
      .def_readonly("frames", &BagSummary::frames);

  m.def("is_bag", &is_bag, "path"_a,
        "Whether path is a ROS 1 .bag or a ROS 2 bag (folder, metadata.yaml or .db3).");
  m.def("summarise_bag", &summarise_bag, "path"_a, "options"_a = BagOptions{},
        py::call_guard<py::gil_scoped_release>(),
        "The bag's topics and the topic, type and pose source options would map.");
  m.def("read_bag", &read_bag, "path"_a, "options"_a = BagOptions{},
        py::call_guard<py::gil_scoped_release>(),
        "The chosen topic's messages with a pose, as scans in the fixed frame (2D for laser\n"
        "scans, 3D keyframes for point clouds). InputError names the bag and what is wrong.");
  m.def("open_bag_drive", &open_bag_drive, "path"_a, "options"_a = BagOptions{},
        py::call_guard<py::gil_scoped_release>(),
        "A point-cloud topic as a Drive: keyframes' poses and times, read one at a time.");
}

}  // namespace potmap::python
