// MapEvaluator's device path (kernels/map/evaluate_cells.cl): points already in a device
// buffer find their kernels through a uniform grid of cells over the map, each listing the
// kernels whose cut-off ball meets it (built on the first call).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "map/evaluator_impl.hpp"
#include "map/split_float.hpp"
#include "potmap/error.hpp"

namespace bc = boost::compute;

namespace potmap {

// Cells of a uniform grid over the map grown by the largest reach; each cell lists the kernels
// whose cut-off ball meets it. The cell edge starts at the smallest reach and doubles until the
// lists fit in 16M entries.
void MapEvaluator::Impl::build_cells() {
  const int dim = map.dim;
  const std::size_t m = map.size();
  constexpr double kMaxEntries = 16.0 * (1 << 20);
  std::vector<double> reach(m);
  double rmin = std::numeric_limits<double>::infinity(), rmax = 0;
  for (std::size_t k = 0; k < m; ++k) {
    reach[k] = std::sqrt(opt.tau / map.gamma[k]);
    rmin = std::min(rmin, reach[k]);
    rmax = std::max(rmax, reach[k]);
  }
  double lo[3], hi[3];
  map.bounds(lo, hi);
  double cs = m ? std::max(rmin, 0.25) : 1.0;
  for (;;) {
    double entries = 0, cells = 1;
    for (int d = 0; d < dim; ++d) cells *= std::ceil((hi[d] - lo[d] + 2 * rmax) / cs) + 1;
    for (std::size_t k = 0; k < m; ++k) entries += std::pow(2 * reach[k] / cs + 2, dim);
    if ((entries <= kMaxEntries && cells <= kMaxEntries) || cs > 1e6) break;
    cs *= 2;
  }
  cell_size = cs;
  std::size_t total = 1;
  for (int d = 0; d < 3; ++d) {
    if (d < dim) {
      cell_lo[d] = lo[d] - rmax - anchor[d];
      cell_n[d] = static_cast<cl_uint>(std::ceil((hi[d] - lo[d] + 2 * rmax) / cs) + 1);
    } else {
      cell_lo[d] = 0;
      cell_n[d] = 1;
    }
    total *= cell_n[d];
  }
  std::vector<std::uint32_t> start(total + 1, 0), list;
  // Two passes over every kernel's cells: count, then fill.
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<std::uint32_t> fill;
    if (pass == 1) {
      for (std::size_t c = 0; c < total; ++c) start[c + 1] += start[c];
      list.resize(std::max<std::size_t>(start[total], 1));
      fill.assign(start.begin(), start.end() - 1);
    }
    for (std::size_t k = 0; k < m; ++k) {
      std::int64_t a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
      double h[3] = {0, 0, 0};
      for (int d = 0; d < dim; ++d) {
        h[d] = map.position[k * dim + d] - anchor[d];
        a[d] = std::max<std::int64_t>(0, std::floor((h[d] - reach[k] - cell_lo[d]) / cs));
        b[d] =
            std::min<std::int64_t>(cell_n[d] - 1, std::floor((h[d] + reach[k] - cell_lo[d]) / cs));
      }
      for (std::int64_t z = a[2]; z <= b[2]; ++z)
        for (std::int64_t y = a[1]; y <= b[1]; ++y)
          for (std::int64_t x = a[0]; x <= b[0]; ++x) {
            const std::int64_t c3[3] = {x, y, z};
            double d2 = 0;
            for (int d = 0; d < dim; ++d) {
              const double l = cell_lo[d] + c3[d] * cs, u = l + cs;
              const double o = std::max({l - h[d], 0.0, h[d] - u});
              d2 += o * o;
            }
            if (map.gamma[k] * d2 > opt.tau) continue;
            const std::size_t c = (z * cell_n[1] + y) * cell_n[0] + x;
            if (pass == 0)
              ++start[c + 1];
            else
              list[fill[c]++] = static_cast<std::uint32_t>(k);
          }
    }
  }
  cell_start_buf = detail::to_device(*ctx, start, "evaluator: cell list starts");
  cell_list_buf = detail::to_device(*ctx, list, "evaluator: cell kernel lists");
  cells_built = true;
}

bc::event MapEvaluator::evaluate_device(const bc::buffer& points, std::size_t n,
                                        const double* origin, bc::buffer* mean, bc::buffer* var,
                                        bc::buffer* prob, const bc::wait_list& events) {
  Impl& im = *impl_;
  im.last_pairs = 0;
  if (n == 0) return bc::event();
  const int dim = im.map.dim;
  if (!origin) throw ArgumentError("MapEvaluator::evaluate_device: origin is null");
  auto check = [&](const bc::buffer* b, std::size_t bytes, const char* what) {
    if (!b) return;
    if (b->get() == nullptr)
      throw ArgumentError(std::string("MapEvaluator::evaluate_device: ") + what +
                          " is an empty buffer");
    if (b->size() < bytes)
      throw ArgumentError(std::string("MapEvaluator::evaluate_device: ") + what + " holds " +
                          std::to_string(b->size()) + " bytes, needs " + std::to_string(bytes));
    if (b->get_context().get() != im.ctx->context().get())
      throw ArgumentError(std::string("MapEvaluator::evaluate_device: ") + what +
                          " belongs to another OpenCL context");
  };
  check(&points, n * dim * sizeof(float), "points");
  check(mean, n * 4, "mean");
  check(var, n * 4, "var");
  check(prob, n * 4, "prob");
  if (!im.cells_built) im.build_cells();
  float oh[4] = {0, 0, 0, 0}, ol[4] = {0, 0, 0, 0}, clo[4] = {0, 0, 0, 0};
  for (int d = 0; d < dim; ++d) {
    detail::split(origin[d] - im.anchor[d], oh[d], ol[d]);
    clo[d] = static_cast<float>(im.cell_lo[d]);
  }
  // Cells are found in float: a point that rounds into a neighbouring cell lies micrometres
  // from it, so all it can miss are kernels at the very edge of their cut-off.
  KernelLease lease =
      im.ctx->lend_kernel("map/evaluate_cells", "map_eval_cells", "-DDIM=" + std::to_string(dim));
  bc::kernel& k = *lease;
  cl_float4 ohv = {{oh[0], oh[1], oh[2], oh[3]}}, olv = {{ol[0], ol[1], ol[2], ol[3]}};
  cl_float4 clov = {{clo[0], clo[1], clo[2], clo[3]}};
  cl_uint4 cnv = {{im.cell_n[0], im.cell_n[1], im.cell_n[2], 1}};
  const float cs = static_cast<float>(im.cell_size);
  detail::set_kernel_args(k, "map_eval_cells", im.kpos_hi, im.kpos_lo, im.kpar, points,
                          static_cast<cl_uint>(n), ohv, olv, clov, cs, cnv, im.cell_start_buf,
                          im.cell_list_buf, im.bias_mean, im.bias_var);
  // Null outputs are passed as null cl_mem, which the kernel tests for.
  detail::set_kernel_arg_or_null(k, "map_eval_cells", 14, mean);
  detail::set_kernel_arg_or_null(k, "map_eval_cells", 15, var);
  detail::set_kernel_arg_or_null(k, "map_eval_cells", 16, prob);
  const std::size_t local = static_cast<std::size_t>(im.tuning.cells_work_group);
  return detail::enqueue_1d(im.ctx->queue(), k, "map_eval_cells", detail::round_up(n, local), local,
                            events);
}

}  // namespace potmap
