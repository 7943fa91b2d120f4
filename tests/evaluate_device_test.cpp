// The device-buffer entry point: points already on the device, in any order.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <boost/compute/buffer.hpp>

#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "test_support.hpp"

using namespace potmap;
namespace bc = boost::compute;

namespace {

KernelMap random_map(int dim, std::size_t m, double extent, double shift, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(0, extent), lg(std::log(0.01), std::log(1.0)),
      w(-10, 10), lv(std::log(1e-6), std::log(1e4));
  KernelMap map;
  map.dim = dim;
  for (std::size_t k = 0; k < m; ++k) {
    double p[3] = {shift + pos(rng), shift + pos(rng), pos(rng) * 0.3};
    map.push_back(p, std::exp(lg(rng)), w(rng), std::exp(lv(rng)));
  }
  return map;
}

void check_device_path(int dim, double shift) {
  Context& ctx = test::context();
  const KernelMap map = random_map(dim, 1500, 60, shift, 21 + dim);
  MapEvaluator ev(ctx, map);
  const std::size_t n = 4000;
  const double origin[3] = {shift + 30, shift + 30, 0};
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-40, 40);
  std::vector<float> local(n * dim);
  std::vector<double> world(n * dim);
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < dim; ++d) {
      local[i * dim + d] = d == 2 ? u(rng) * 0.3f : u(rng);
      world[i * dim + d] = origin[d] + static_cast<double>(local[i * dim + d]);
    }
  bc::buffer pts(ctx.context(), local.size() * 4), mean(ctx.context(), n * 4),
      var(ctx.context(), n * 4), prob(ctx.context(), n * 4);
  bc::event up = ctx.queue().enqueue_write_buffer_async(pts, 0, local.size() * 4, local.data());
  bc::event done = ev.evaluate_device(pts, n, origin, &mean, &var, &prob, bc::wait_list(up));
  done.wait();
  std::vector<float> m(n), v(n), p(n);
  ctx.queue().enqueue_read_buffer(mean, 0, n * 4, m.data());
  ctx.queue().enqueue_read_buffer(var, 0, n * 4, v.data());
  ctx.queue().enqueue_read_buffer(prob, 0, n * 4, p.data());
  const MapValuesExact ref = evaluate_exact(map, world.data(), n);
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_NEAR(p[i], ref.prob[i], 1e-6) << i;
    ASSERT_NEAR(m[i], ref.mean[i], 1e-5 * (1 + std::abs(ref.mean[i]))) << i;
    ASSERT_NEAR(v[i], ref.var[i], 1e-5 * (1 + ref.var[i])) << i;
  }
}

}  // namespace

TEST(MapEvalDevice, Points2DMatchExactReference) {
  check_device_path(2, 0.0);
}
TEST(MapEvalDevice, Points3DMatchExactReference) {
  check_device_path(3, 0.0);
}
TEST(MapEvalDevice, FarFrameKeepsPrecision) {
  check_device_path(2, 431234.0);
}

TEST(MapEvalDevice, NullOutputsAreSkippedAndEmptyIsANoOp) {
  Context& ctx = test::context();
  MapEvaluator ev(ctx, random_map(2, 50, 10, 0, 3));
  bc::buffer pts(ctx.context(), 8 * 4), prob(ctx.context(), 4 * 4);
  const float p[8] = {1, 1, 2, 2, 3, 3, 4, 4};
  ctx.queue().enqueue_write_buffer(pts, 0, sizeof p, p);
  const double origin[2] = {0, 0};
  ev.evaluate_device(pts, 4, origin, nullptr, nullptr, &prob).wait();
  float out[4];
  ctx.queue().enqueue_read_buffer(prob, 0, sizeof out, out);
  for (float x : out) EXPECT_TRUE(x >= 0 && x <= 1);
  EXPECT_NO_THROW(ev.evaluate_device(pts, 0, origin, nullptr, nullptr, nullptr));
}

TEST(MapEvalDevice, BadBuffersAreRejected) {
  Context& ctx = test::context();
  MapEvaluator ev(ctx, random_map(2, 50, 10, 0, 4));
  bc::buffer pts(ctx.context(), 8 * 4), small(ctx.context(), 4);
  const double origin[2] = {0, 0};
  EXPECT_THROW(ev.evaluate_device(pts, 5, origin, nullptr, nullptr, nullptr), ArgumentError);
  EXPECT_THROW(ev.evaluate_device(pts, 4, origin, &small, nullptr, nullptr), ArgumentError);
  EXPECT_THROW(ev.evaluate_device(pts, 4, nullptr, nullptr, nullptr, nullptr), ArgumentError);
  Context other;
  bc::buffer foreign(other.context(), 64);
  EXPECT_THROW(ev.evaluate_device(foreign, 4, origin, nullptr, nullptr, nullptr), ArgumentError);
}
