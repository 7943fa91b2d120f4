#include "pot/overall_map_state.hpp"

#include <string>

namespace potmap::detail {

void OverallMapState::write(ContainerWriter& w, const OverallMap& m) {
  w.u32(static_cast<std::uint32_t>(m.dim_));
  w.f64(m.opt_.merge_radius);
  w.f64(m.opt_.gamma_ratio);
  w.f64(double(m.opt_.max_kernels));
  w.f64(m.opt_.retire_to);
  for (const auto* v : {&m.map_.position, &m.map_.gamma, &m.map_.w_mean, &m.map_.w_var})
    put_f64s(w, *v);
  put_uints(w, m.count_);
  put_uints(w, m.last_seen_);
  put_uints(w, m.born_);
  w.f64(m.cell_);
  w.u64(m.adds_);
  // The index's bucket count: memory_bytes() then reports what the saved map did.
  w.u64(m.grid_.bucket_count());
}

void OverallMapState::read(ContainerCursor& c, OverallMap& m) {
  std::size_t at = c.at();
  const std::uint32_t dim = c.u32();
  if (dim != static_cast<std::uint32_t>(m.dim_))
    c.reader().fail(at, "overall map state: dimension " + std::to_string(dim) +
                            ", the map it is restored into is " + std::to_string(m.dim_) + "D");
  expect_same_f64(c, "overall map state", "merge radius", m.opt_.merge_radius);
  expect_same_f64(c, "overall map state", "gamma ratio", m.opt_.gamma_ratio);
  expect_same_f64(c, "overall map state", "max kernels", double(m.opt_.max_kernels));
  expect_same_f64(c, "overall map state", "retire_to", m.opt_.retire_to);
  KernelMap k;
  k.dim = m.dim_;
  at = c.at();
  k.position = c.f64s("kernel positions");
  k.gamma = c.f64s("kernel widths");
  k.w_mean = c.f64s("weight means");
  k.w_var = c.f64s("weight variances");
  std::vector<std::uint32_t> count = c.uints<std::uint32_t>("merge counts");
  std::vector<std::uint64_t> last_seen = c.uints<std::uint64_t>("last seen");
  std::vector<std::uint64_t> born = c.uints<std::uint64_t>("born");
  const std::size_t n = k.gamma.size();
  if (k.position.size() != n * m.dim_ || k.w_mean.size() != n || k.w_var.size() != n ||
      count.size() != n || last_seen.size() != n || born.size() != n)
    c.reader().fail(at, "overall map state: the kernel arrays disagree in length (" +
                            std::to_string(n) + " widths)");
  k.validate(c.reader().path());
  at = c.at();
  const double cell = c.f64();
  if (!(cell >= 0) || (n > 0 && !(cell > 0)))
    c.reader().fail(at, "overall map state: index cell " + std::to_string(cell));
  const std::uint64_t adds = c.u64();
  const std::uint64_t buckets = c.u64();
  m.map_ = std::move(k);
  m.count_ = std::move(count);
  m.last_seen_ = std::move(last_seen);
  m.born_ = std::move(born);
  m.cell_ = cell;
  m.adds_ = adds;
  m.grid_.clear();
  if (buckets < (std::uint64_t(1) << 40)) m.grid_.rehash(static_cast<std::size_t>(buckets));
  if (m.cell_ > 0)
    for (std::size_t i = 0; i < n; ++i) m.index_insert(static_cast<std::uint32_t>(i));
}

}  // namespace potmap::detail
