// MapEvaluator's block path (kernels/map/blocks.cl): a 3D map's volume in blocks of 16^3 voxels,
// a work-group a block, each block with the list of kernels whose cut-off reaches its voxel
// centres; and the blocks' exact reference.

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <string>

#include "map/evaluator_impl.hpp"
#include "potmap/error.hpp"
#include "potmap/map/voxel_blocks.hpp"

namespace bc = boost::compute;

namespace potmap {

namespace {

constexpr std::size_t kItemsPerBlock = 32;  // blocks.cl: 8 y pairs by 4 z quads

void check_blocks(const VoxelBlocks& blocks, int dim, const char* who) {
  if (dim != 3)
    throw ArgumentError(std::string(who) + ": the map is " + std::to_string(dim) +
                        "D; voxel blocks need a 3D map");
  if (!(blocks.voxel > 0) || !std::isfinite(blocks.voxel))
    throw ArgumentError(std::string(who) + ": the voxel edge must be positive, got " +
                        std::to_string(blocks.voxel));
  if (blocks.index.size() % 3 != 0)
    throw ArgumentError(std::string(who) + ": the block index holds " +
                        std::to_string(blocks.index.size()) + " numbers, not 3 a block");
}

// The box of block b's voxel centres.
void centre_box(const VoxelBlocks& blocks, std::size_t b, double lo[3], double hi[3]) {
  for (int d = 0; d < 3; ++d) {
    lo[d] = blocks.corner(b, d) + 0.5 * blocks.voxel;
    hi[d] = lo[d] + (VoxelBlocks::kSide - 1) * blocks.voxel;
  }
}

}  // namespace

void MapEvaluator::Impl::run_blocks(const VoxelBlocks& blocks, float* out_v, float* out_p,
                                    float* out_s) {
  last_pairs = 0;
  check_blocks(blocks, map.dim, "MapEvaluator::evaluate_blocks");
  const std::size_t n = blocks.size();
  if (n == 0) return;
  const std::size_t per_launch =
      std::max<std::size_t>(1, opt.cells_per_launch / VoxelBlocks::kVoxels);
  auto& cx = ctx->context();
  auto& q = ctx->queue();
  char defs[80];
  std::snprintf(defs, sizeof defs, "-DTAU=%#.9gf -cl-denorms-are-zero", opt.tau);
  KernelLease lease = ctx->lend_kernel("map/blocks", "map_blocks", defs);

  std::vector<std::uint32_t> start, scratch;
  std::vector<float> ex, ey, ez, eg, ewm, ewv;
  for (std::size_t b0 = 0; b0 < n; b0 += per_launch) {
    const std::size_t nb = std::min(n, b0 + per_launch) - b0;
    start.assign(1, 0);
    for (auto* v : {&ex, &ey, &ez, &eg, &ewm, &ewv}) v->clear();
    for (std::size_t b = 0; b < nb; ++b) {
      double lo[3], hi[3];
      centre_box(blocks, b0 + b, lo, hi);
      scratch.clear();
      index.query_box(lo, hi, scratch);
      const double c[3] = {blocks.corner(b0 + b, 0), blocks.corner(b0 + b, 1),
                           blocks.corner(b0 + b, 2)};
      for (std::uint32_t k : scratch) {
        ex.push_back(static_cast<float>(c[0] - map.position[3 * k]));
        ey.push_back(static_cast<float>(c[1] - map.position[3 * k + 1]));
        ez.push_back(static_cast<float>(c[2] - map.position[3 * k + 2]));
        eg.push_back(static_cast<float>(map.gamma[k]));
        ewm.push_back(static_cast<float>(map.w_mean[k]));
        ewv.push_back(static_cast<float>(map.w_var[k]));
      }
      start.push_back(static_cast<std::uint32_t>(ex.size()));
    }
    if (ex.empty())  // a buffer is never empty
      for (auto* v : {&ex, &ey, &ez, &eg, &ewm, &ewv}) v->push_back(0.f);
    last_pairs += std::size_t(start.back()) * VoxelBlocks::kVoxels;

    const std::size_t cells = nb * VoxelBlocks::kVoxels;
    detail::BatchedReads reads(q);  // after the vectors it reads: see its comment
    bc::buffer& b_x = blk_x.put(cx, q, ex);
    bc::buffer& b_y = blk_y.put(cx, q, ey);
    bc::buffer& b_z = blk_z.put(cx, q, ez);
    bc::buffer& b_g = blk_g.put(cx, q, eg);
    bc::buffer& b_wm = blk_wm.put(cx, q, ewm);
    bc::buffer& b_wv = blk_wv.put(cx, q, ewv);
    bc::buffer& b_start = g_start.put(cx, q, start);
    bc::buffer& b_v = out_var.get(cx, cells * 4);
    bc::buffer& b_p = out_prob.get(cx, cells * 4);
    bc::buffer& b_s = out_mean.get(cx, cells * 4);  // the support in the mean's buffer
    detail::set_kernel_args(*lease, "map_blocks", b_x, b_y, b_z, b_g, b_wm, b_wv, b_start,
                            static_cast<float>(blocks.voxel), bias_mean, bias_var, b_v, b_p, b_s);
    detail::enqueue_1d(q, *lease, "map_blocks", nb * kItemsPerBlock, kItemsPerBlock);
    float* const dsts[3] = {out_v, out_p, out_s};
    bc::buffer* const bufs[3] = {&b_v, &b_p, &b_s};
    for (int o = 0; o < 3; ++o)
      if (dsts[o]) reads.bytes(*bufs[o], cells * 4, dsts[o] + b0 * VoxelBlocks::kVoxels);
    reads.wait();
  }
}

void MapEvaluator::evaluate_blocks(const VoxelBlocks& blocks, float* var, float* prob,
                                   float* support) {
  impl_->run_blocks(blocks, var, prob, support);
}

VoxelBlocks blocks_holding_kernels(const KernelMap& map, double voxel) {
  VoxelBlocks blocks;
  blocks.voxel = voxel;
  check_blocks(blocks, map.dim, "blocks_holding_kernels");
  const double edge = VoxelBlocks::kSide * voxel;
  std::vector<std::array<std::int64_t, 3>> zyx;
  zyx.reserve(map.size() / 64 + 1);
  for (std::size_t k = 0; k < map.size(); ++k) {
    std::array<std::int64_t, 3> c;
    for (int d = 0; d < 3; ++d)
      c[2 - d] = static_cast<std::int64_t>(std::floor(map.position[3 * k + d] / edge));
    zyx.push_back(c);
  }
  std::sort(zyx.begin(), zyx.end());
  zyx.erase(std::unique(zyx.begin(), zyx.end()), zyx.end());
  blocks.index.reserve(3 * zyx.size());
  for (const auto& c : zyx) blocks.index.insert(blocks.index.end(), {c[2], c[1], c[0]});
  return blocks;
}

BlockValues evaluate_blocks_exact(const KernelMap& map, const VoxelBlocks& blocks) {
  check_blocks(blocks, map.dim, "evaluate_blocks_exact");
  const std::size_t n = blocks.size() * VoxelBlocks::kVoxels;
  std::vector<double> pts;
  pts.reserve(3 * n);
  for (std::size_t b = 0; b < blocks.size(); ++b)
    for (int k = 0; k < VoxelBlocks::kSide; ++k)
      for (int j = 0; j < VoxelBlocks::kSide; ++j)
        for (int i = 0; i < VoxelBlocks::kSide; ++i) {
          const int at[3] = {i, j, k};
          for (int d = 0; d < 3; ++d)
            pts.push_back(blocks.corner(b, d) + (at[d] + 0.5) * blocks.voxel);
        }
  BlockValues out;
  MapValuesExact x = evaluate_exact(map, pts.data(), n);
  out.var = std::move(x.var);
  out.prob = std::move(x.prob);
  // The support is the variance of the same kernels with unit weight variance and no bias.
  KernelMap unit = map;
  unit.w_mean.assign(map.size(), 0.0);
  unit.w_var.assign(map.size(), 1.0);
  unit.has_bias = false;
  out.support = evaluate_exact(unit, pts.data(), n).var;
  return out;
}

}  // namespace potmap
