// C API: scans described by the caller, and scans read from dataset files.
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "capi_handles.hpp"
#include "capi_structs.hpp"
#include "potmap/data/bag.hpp"

namespace potmap::capi {
namespace {

potmap_scan default_scan() {
  potmap_scan s{};
  s.struct_size = sizeof s;
  s.dim = 2;
  const double identity[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  std::copy(identity, identity + 12, s.pose);
  return s;
}

void check_finite(double v, const std::string& what) {
  if (!std::isfinite(v))
    fail(POTMAP_ERROR_INVALID_ARGUMENT, what + " must be finite, got " + std::to_string(v));
}

std::vector<double> copy_points(const double* p, std::size_t n, int dim, const std::string& what) {
  if (n == 0) return {};
  if (!p) fail(POTMAP_ERROR_NULL_ARGUMENT, what + " is null with " + std::to_string(n) + " points");
  if (n > std::numeric_limits<std::size_t>::max() / (8 * 3))
    fail(POTMAP_ERROR_INVALID_ARGUMENT, what + ": " + std::to_string(n) + " points is too many");
  return std::vector<double>(p, p + n * dim);
}

}  // namespace

Scan to_scan(const potmap_scan* scan, const std::string& what) {
  if (!scan) fail(POTMAP_ERROR_NULL_ARGUMENT, what + " is null");
  const potmap_scan s = read_struct(scan, default_scan(), kScanV1, what.c_str());
  if (s.dim != 2 && s.dim != 3)
    fail(POTMAP_ERROR_INVALID_ARGUMENT,
         what + "->dim must be 2 or 3, got " + std::to_string(s.dim));
  if (!(s.max_range > 0) || !std::isfinite(s.max_range))
    fail(POTMAP_ERROR_INVALID_ARGUMENT,
         what + "->max_range must be finite and > 0 metres, got " + std::to_string(s.max_range));
  Scan out;
  out.dim = s.dim;
  out.max_range = s.max_range;
  out.timestamp = s.timestamp;
  const int pose_values = s.dim == 2 ? 3 : 12;
  for (int i = 0; i < pose_values; ++i)
    check_finite(s.pose[i], what + "->pose[" + std::to_string(i) + "]");
  if (s.dim == 2)
    std::copy(s.pose, s.pose + 3, out.pose2d.begin());
  else
    std::copy(s.pose, s.pose + 12, out.pose3d.begin());
  // Non-finite points are not refused: labelling drops them, as the dataset readers do.
  out.hits = copy_points(s.hits, s.num_hits, s.dim, what + "->hits");
  out.no_return = copy_points(s.no_return, s.num_no_return, s.dim, what + "->no_return");
  return out;
}

std::vector<Scan> to_scans(const potmap_scan* const* scans, std::size_t n) {
  if (n > 0) require(scans, "scans");
  std::vector<Scan> out;
  out.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    out.push_back(to_scan(scans[i], "scans[" + std::to_string(i) + "]"));
    if (out[i].dim != out[0].dim)
      fail(POTMAP_ERROR_DIMENSION_MISMATCH, "scans[" + std::to_string(i) + "] is " +
                                                std::to_string(out[i].dim) + "D, scans[0] " +
                                                std::to_string(out[0].dim) + "D");
  }
  return out;
}

}  // namespace potmap::capi

namespace potmap::capi {
namespace {

potmap_bag_options default_bag_options() {
  const potmap::BagOptions d;
  potmap_bag_options o{};
  o.struct_size = sizeof o;
  o.max_range = d.max_range;
  o.keyframe_distance = d.keyframe_distance;
  o.keyframe_angle = d.keyframe_angle;
  return o;
}

potmap::BagOptions to_bag_options(const potmap_bag_options* in) {
  const potmap_bag_options o =
      in ? read_struct(in, default_bag_options(), kBagOptionsV1, "options") : default_bag_options();
  auto bad = [](const std::string& field, double v) {
    fail(POTMAP_ERROR_INVALID_ARGUMENT,
         "options->" + field + " is out of range: " + std::to_string(v));
  };
  if (!(o.max_range >= 0) || !std::isfinite(o.max_range)) bad("max_range", o.max_range);
  if (!(o.keyframe_distance >= 0) || !std::isfinite(o.keyframe_distance))
    bad("keyframe_distance", o.keyframe_distance);
  if (!(o.keyframe_angle >= 0) || !std::isfinite(o.keyframe_angle))
    bad("keyframe_angle", o.keyframe_angle);
  potmap::BagOptions r;
  r.topic = o.topic ? o.topic : "";
  r.fixed_frame = o.fixed_frame ? o.fixed_frame : "";
  r.pose_topic = o.pose_topic ? o.pose_topic : "";
  r.max_range = o.max_range;
  r.keyframe_distance = o.keyframe_distance;
  r.keyframe_angle = o.keyframe_angle;
  return r;
}

}  // namespace
}  // namespace potmap::capi

using namespace potmap::capi;

extern "C" {

potmap_status potmap_scan_init(potmap_scan* scan, size_t struct_size) {
  return guard("potmap_scan_init", POTMAP_ERROR_INTERNAL,
               [&] { init_struct(scan, struct_size, default_scan(), kScanV1, "scan"); });
}

potmap_status potmap_dataset_load(const char* path, potmap_dataset** out) {
  return guard("potmap_dataset_load", POTMAP_ERROR_INPUT, [&] {
    require(path, "path");
    require(out, "out");
    auto h = std::make_unique<potmap_dataset>();
    h->data = potmap::read_dataset(path);
    *out = h.release();
  });
}

potmap_status potmap_bag_options_init(potmap_bag_options* options, size_t struct_size) {
  return guard("potmap_bag_options_init", POTMAP_ERROR_INTERNAL, [&] {
    init_struct(options, struct_size, default_bag_options(), kBagOptionsV1, "options");
  });
}

potmap_status potmap_dataset_load_bag(const char* path, const potmap_bag_options* options,
                                      potmap_dataset** out) {
  return guard("potmap_dataset_load_bag", POTMAP_ERROR_INPUT, [&] {
    require(path, "path");
    require(out, "out");
    const potmap::BagOptions o = to_bag_options(options);
    auto h = std::make_unique<potmap_dataset>();
    h->data = potmap::read_bag(path, o);
    *out = h.release();
  });
}

potmap_status potmap_dataset_destroy(potmap_dataset* dataset) {
  return destroy(dataset, kDatasetTag, "potmap_dataset_destroy");
}

potmap_status potmap_dataset_size(const potmap_dataset* dataset, size_t* count) {
  return guard("potmap_dataset_size", POTMAP_ERROR_INTERNAL, [&] {
    const potmap_dataset& d = checked(dataset);
    require(count, "count");
    *count = d.data.scans.size();
  });
}

potmap_status potmap_dataset_scan(const potmap_dataset* dataset, size_t index, potmap_scan* scan) {
  return guard("potmap_dataset_scan", POTMAP_ERROR_INTERNAL, [&] {
    const potmap_dataset& d = checked(dataset);
    require(scan, "scan");
    if (index >= d.data.scans.size())
      fail(POTMAP_ERROR_INVALID_ARGUMENT, "index " + std::to_string(index) +
                                              " is out of range: the dataset has " +
                                              std::to_string(d.data.scans.size()) + " scans");
    const potmap::Scan& s = d.data.scans[index];
    potmap_scan r = default_scan();
    r.dim = s.dim;
    if (s.dim == 2)
      std::copy(s.pose2d.begin(), s.pose2d.end(), r.pose);
    else
      std::copy(s.pose3d.begin(), s.pose3d.end(), r.pose);
    r.max_range = s.max_range;
    r.timestamp = s.timestamp;
    r.hits = s.hits.empty() ? nullptr : s.hits.data();
    r.num_hits = s.num_hits();
    r.no_return = s.no_return.empty() ? nullptr : s.no_return.data();
    r.num_no_return = s.num_no_return();
    write_struct(scan, r, kScanV1, "scan", POTMAP_ERROR_INVALID_ARGUMENT);
  });
}

}  // extern "C"
