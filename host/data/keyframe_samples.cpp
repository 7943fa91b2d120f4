// A keyframe's training samples gathered per voxel: the plan the host makes, the host
// reference of the gathering and the choice between it and the device (keyframe_plan.hpp).
#include "potmap/data/keyframe_samples.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "beam_samples.hpp"
#include "keyframe_plan.hpp"
#include "potmap/error.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap {

namespace data {

bool gather_on_device(Context& ctx, const KeyframePlan& plan, double voxel,
                      std::vector<VoxelSum>& out);

namespace {

void push(LabelledPoints& lp, const double* p, std::uint8_t y, std::int64_t t) {
  lp.position.insert(lp.position.end(), p, p + 3);
  lp.label.push_back(y);
  lp.scan.push_back(t);
}

void check_inputs(const Scan& scan, double voxel, const LabelOptions& o) {
  if (scan.dim != 3)
    throw ArgumentError("gather_keyframe: the scan is " + std::to_string(scan.dim) + "D, not 3D");
  if (!(voxel > 0) || !std::isfinite(voxel))
    throw ArgumentError("gather_keyframe: voxel edge must be positive, got " +
                        std::to_string(voxel));
  check_label_options(o, "gather_keyframe");
  if (o.max_free_per_beam >= (1L << 31))
    throw ArgumentError("gather_keyframe: max_free_per_beam must be below 2^31");
}

// The sample's voxel key and its place in the voxel, as gather_voxels.cl computes them.
void sample_key(const double q[3], double inv, std::uint64_t label, VoxelSum& v) {
  std::uint64_t k = 0;
  for (int d = 2; d >= 0; --d) {
    const double s = q[d] * inv;
    const double c = std::floor(s);
    const double f = (s - c) * kFracOne;
    v.sum[d] = f < kFracOne ? static_cast<std::uint64_t>(f) : std::uint64_t(kFracOne) - 1;
    k = (k << kAxisBits) | static_cast<std::uint64_t>(static_cast<std::int64_t>(c) + kAxisHalf);
  }
  v.key = (k << 1) | label;
  v.count = 1;
}

}  // namespace

KeyframePlan plan_keyframe(const Scan& scan, std::int64_t scan_index, const LabelOptions& o) {
  KeyframePlan plan;
  plan.out.train.dim = plan.out.test.dim = 3;
  const std::size_t nb = scan.num_beams();
  const auto org = scan.origin();
  std::copy(org.begin(), org.end(), plan.origin);
  if (nb == 0) return plan;
  SimRng rng = split_rng(scan_index, o);
  const std::vector<std::uint8_t> held = draw_split(nb, o, rng);
  const double rmax = scan.max_range > 0 ? scan.max_range : HUGE_VAL;
  double q[3];
  for (std::size_t b = 0; b < nb; ++b) {
    BeamSegment beam;
    if (!beam_segment(scan, b, plan.origin, rmax, beam)) {
      ++plan.out.points_dropped;
      continue;
    }
    const long nfree = free_samples(beam.len, o);
    if (held[b]) {
      if (beam.hit) push(plan.out.test, beam.end, 1, scan_index);
      for (long j = 0; j < nfree; ++j) {
        const double s = rng.uniform() * beam.len;
        for (int k = 0; k < 3; ++k) q[k] = plan.origin[k] + s * beam.dir[k];
        push(plan.out.test, q, 0, scan_index);
      }
      continue;
    }
    plan.dir.insert(plan.dir.end(), beam.dir, beam.dir + 3);
    plan.end.insert(plan.end.end(), beam.end, beam.end + 3);
    plan.len.push_back(beam.len);
    plan.state.push_back(rng.s);
    plan.draws_hit.push_back(std::uint32_t(nfree) | (beam.hit ? 1u << 31 : 0u));
    rng.s += std::uint64_t(nfree) * kGolden;  // the beam's draws, made where it is gathered
    plan.samples += std::size_t(nfree) + (beam.hit ? 1 : 0);
    plan.reach = std::max(plan.reach, beam.len);
  }
  return plan;
}

bool plan_fits_keys(const KeyframePlan& plan, double voxel) {
  // Two voxels of room for the rounding of a sample's place.
  const double limit = double(kAxisLimit - 2) * voxel;
  for (int d = 0; d < 3; ++d)
    if (!(std::abs(plan.origin[d]) + plan.reach < limit)) return false;
  return true;
}

LabelledPoints voxels_to_samples(std::vector<VoxelSum>& voxels, double voxel,
                                 std::int64_t scan_index) {
  std::sort(voxels.begin(), voxels.end(),
            [](const VoxelSum& a, const VoxelSum& b) { return a.key < b.key; });
  LabelledPoints out;
  out.dim = 3;
  out.position.reserve(3 * voxels.size());
  out.label.reserve(voxels.size());
  out.weight.reserve(voxels.size());
  const std::uint64_t mask = (std::uint64_t(1) << kAxisBits) - 1;
  for (const VoxelSum& v : voxels) {
    const double n = double(v.count);
    for (int d = 0; d < 3; ++d) {
      const double c = double(std::int64_t((v.key >> (1 + kAxisBits * d)) & mask) - kAxisHalf);
      out.position.push_back((c + (double(v.sum[d]) + 0.5 * n) / (n * kFracOne)) * voxel);
    }
    out.label.push_back(std::uint8_t(v.key & 1));
    out.weight.push_back(n);
  }
  out.scan.assign(voxels.size(), scan_index);
  return out;
}

}  // namespace data

namespace {

std::vector<data::VoxelSum> gather_on_host(const data::KeyframePlan& plan, double voxel) {
  std::vector<data::VoxelSum> all;
  all.reserve(plan.samples);
  const double inv = 1.0 / voxel;
  double q[3];
  for (std::size_t i = 0; i < plan.len.size(); ++i) {
    data::VoxelSum v;
    if (plan.draws_hit[i] >> 31) {
      data::sample_key(&plan.end[3 * i], inv, 1, v);
      all.push_back(v);
    }
    data::SimRng rng{plan.state[i]};
    const std::uint32_t draws = plan.draws_hit[i] & 0x7fffffffu;
    for (std::uint32_t j = 0; j < draws; ++j) {
      const double s = rng.uniform() * plan.len[i];
      for (int k = 0; k < 3; ++k) q[k] = plan.origin[k] + s * plan.dir[3 * i + k];
      data::sample_key(q, inv, 0, v);
      all.push_back(v);
    }
  }
  std::sort(all.begin(), all.end(),
            [](const data::VoxelSum& a, const data::VoxelSum& b) { return a.key < b.key; });
  std::vector<data::VoxelSum> out;
  for (const data::VoxelSum& v : all) {
    if (out.empty() || out.back().key != v.key) {
      out.push_back(v);
      continue;
    }
    data::VoxelSum& o = out.back();
    ++o.count;
    for (int d = 0; d < 3; ++d) o.sum[d] += v.sum[d];
  }
  return out;
}

// The keyframe planned once; its training beams gathered on `ctx` when it has what the
// kernel needs, else on the host (the same result).
KeyframeSamples gather(const Scan& scan, std::int64_t scan_index, const LabelOptions& options,
                       double voxel, Context* ctx) {
  data::check_inputs(scan, voxel, options);
  data::KeyframePlan plan = data::plan_keyframe(scan, scan_index, options);
  KeyframeSamples out = std::move(plan.out);
  out.samples = plan.samples;
  if (!data::plan_fits_keys(plan, voxel)) {
    // Too far from the origin for the keys: label_scan's samples gathered one by one.
    LabelledSplit split;
    label_scan(scan, scan_index, options, split);
    out.train = aggregate_voxels(split.train, voxel);
    return out;
  }
  std::vector<data::VoxelSum> voxels;
  if (ctx && ctx->info().has_fp64 && ctx->info().has_int64_atomics)
    out.on_device = data::gather_on_device(*ctx, plan, voxel, voxels);
  if (!out.on_device) voxels = gather_on_host(plan, voxel);
  out.train = data::voxels_to_samples(voxels, voxel, scan_index);
  return out;
}

}  // namespace

KeyframeSamples gather_keyframe_reference(const Scan& scan, std::int64_t scan_index,
                                          const LabelOptions& options, double voxel) {
  return gather(scan, scan_index, options, voxel, nullptr);
}

KeyframeSamples gather_keyframe(const Scan& scan, std::int64_t scan_index,
                                const LabelOptions& options, double voxel, Context* ctx) {
  return gather(scan, scan_index, options, voxel, ctx);
}

}  // namespace potmap
