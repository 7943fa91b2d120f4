// The device path of gather_keyframe() (kernels/data/gather_voxels.cl): the plan's training
// beams uploaded, drawn and gathered into a table of twice as many slots as samples (a load of
// at most one half: short probes), the used slots packed and read back.
#include <boost/compute/buffer.hpp>
#include <boost/compute/kernel.hpp>
#include <cstdint>
#include <vector>

#include "keyframe_plan.hpp"
#include "runtime/cl_check.hpp"
#include "runtime/device_buffers.hpp"

namespace potmap::data {

namespace bc = boost::compute;
using detail::device_buffer;
using detail::round_up;
using detail::to_device;

bool gather_on_device(Context& ctx, const KeyframePlan& plan, double voxel,
                      std::vector<VoxelSum>& out) {
  out.clear();
  const std::size_t beams = plan.len.size();
  if (beams == 0) return true;
  std::uint64_t slots = 1024;
  while (slots < 2 * std::uint64_t(plan.samples)) slots *= 2;
  bc::context& cx = ctx.context();
  bc::buffer b_dir = to_device(ctx, plan.dir, "gather: beam directions"),
             b_len = to_device(ctx, plan.len, "gather: beam lengths"),
             b_end = to_device(ctx, plan.end, "gather: beam end points"),
             b_state = to_device(ctx, plan.state, "gather: beam generator states"),
             b_draws = to_device(ctx, plan.draws_hit, "gather: beam draws"),
             b_keys = device_buffer(cx, slots * 8, "gather: voxel keys"),
             b_counts = device_buffer(cx, slots * 4, "gather: voxel counts"),
             b_sums = device_buffer(cx, slots * 24, "gather: voxel sums"),
             b_flags = to_device(ctx, std::vector<cl_uint>{0, 0}, "gather: flags and count");
  const std::size_t cap = std::min<std::uint64_t>(slots, plan.samples);
  bc::buffer o_keys = device_buffer(cx, cap * 8, "gather: packed keys"),
             o_counts = device_buffer(cx, cap * 4, "gather: packed counts"),
             o_sums = device_buffer(cx, cap * 24, "gather: packed sums");
  bc::buffer b_used = to_device(ctx, std::vector<cl_uint>{0}, "gather: packed count");
  KernelLease clear_l = ctx.lend_kernel("data/gather_voxels", "gather_clear");
  KernelLease beams_l = ctx.lend_kernel("data/gather_voxels", "gather_beams");
  KernelLease compact_l = ctx.lend_kernel("data/gather_voxels", "gather_compact");
  bc::command_queue& q = ctx.queue();
  const std::size_t wg = 64;
  const cl_ulong n_slots = slots, mask = slots - 1;
  detail::launch_1d(q, *clear_l, "gather_clear", round_up(slots, wg), wg, b_keys, b_counts, b_sums,
                    n_slots);
  detail::launch_1d(q, *beams_l, "gather_beams", round_up(beams, wg), wg, plan.origin[0],
                    plan.origin[1], plan.origin[2], 1.0 / voxel, b_dir, b_len, b_end, b_state,
                    b_draws, static_cast<cl_uint>(beams), b_keys, b_counts, b_sums, mask, b_flags);
  detail::launch_1d(q, *compact_l, "gather_compact", round_up(slots, wg), wg, b_keys, b_counts,
                    b_sums, n_slots, o_keys, o_counts, o_sums, b_used);
  cl_uint flags_used[3] = {0, 0, 0};
  detail::read_bytes(q, b_flags, 4, &flags_used[0]);
  detail::read_bytes(q, b_used, 4, &flags_used[2]);
  if (flags_used[0] != 0) return false;
  const std::size_t used = flags_used[2];
  std::vector<cl_ulong> keys(used), sums(3 * used);
  std::vector<cl_uint> counts(used);
  {
    detail::BatchedReads reads(q);
    reads.read(o_keys, keys);
    reads.read(o_counts, counts);
    reads.read(o_sums, sums);
    reads.wait();
  }
  out.resize(used);
  for (std::size_t i = 0; i < used; ++i) {
    VoxelSum& v = out[i];
    v.key = keys[i];
    v.count = counts[i];
    for (int d = 0; d < 3; ++d) v.sum[d] = sums[3 * i + d];
  }
  return true;
}

}  // namespace potmap::data
