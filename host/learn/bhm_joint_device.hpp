#pragma once
// The device path of JointBhm::update() (bhm_joint_device.cpp, kernels/learn/bhm_joint_sums.cl):
// the buffers of one scan's features and row lists, kept on the device across its EM rounds.

#include <boost/compute/buffer.hpp>
#include <cstdint>
#include <vector>

#include "potmap/learn/bhm_joint.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap::detail {

/// Whether update() sums on the device for `sums` and the context's device.
bool sums_on_device(JointBhmSums sums, const DeviceInfo& info);

/// The grid as the kernels read it (JointGrid in bhm_joint_sums.cl: the same layout).
struct JointGridArgs {
  double lo[3];
  double h, gamma, tau;
  std::int32_t dim, tile, tile_cells, box;
};
static_assert(sizeof(JointGridArgs) == 64, "JointGrid's layout");

struct JointDeviceScan;

/// The device's update, a friend of JointBhm (hidden, as every detail type: no exported
/// member names it).
struct JointBhmDevice {
  static void update(JointBhm& m, const LabelledPoints& samples, Context& ctx);
  static void list(JointBhm& m, const LabelledPoints& samples, JointDeviceScan& dev);
  static void apply_round(JointBhm& m, JointDeviceScan& dev, int round);
};

struct JointDeviceScan {
  explicit JointDeviceScan(Context& c) : ctx(c) {}
  Context& ctx;
  std::size_t samples = 0;           // samples with a span (featureless ones included)
  std::size_t features = 0;          // over all samples
  std::vector<std::uint32_t> start;  // per sample: first feature, and one past the last
  std::vector<std::uint8_t> has;     // per sample: it has features
  std::vector<double> yc, w;         // per sample, as FeatureList's
  // Host copies of one round's results: per sample c and mu; per row its half stencil's
  // increments, then (bias coupling, carried residual, eta) increments.
  std::vector<double> c, mu, dprec, drow;
  boost::compute::buffer start_b, w_b, yc_b, fkernel_b, fphi_b, flocal_b, fsample_b, frow_b;
  boost::compute::buffer rstart_b, rlist_b, half_at_b, lambda_b, c_b, mu_b, dprec_b, drow_b;
  boost::compute::buffer row_mean_b, row_diag_b;
};

}  // namespace potmap::detail
