#include "pot/averaged_map_state.hpp"

#include <cmath>
#include <string>

namespace potmap::detail {

void AveragedMapState::write(ContainerWriter& w, const AveragedMap& m) {
  w.u32(static_cast<std::uint32_t>(m.dim_));
  w.f64(m.opt_.spacing);
  w.f64(m.opt_.min_support);
  w.f64(m.opt_.ridge);
  w.f64(double(m.opt_.sweeps));
  for (const auto* v : {&m.map_.position, &m.map_.gamma, &m.map_.w_mean, &m.map_.w_var, &m.sum_sm_,
                        &m.sum_s_, &m.sum_sv_, &m.sum_sg_})
    put_f64s(w, *v);
}

void AveragedMapState::read(ContainerCursor& c, AveragedMap& m) {
  std::size_t at = c.at();
  const std::uint32_t dim = c.u32();
  if (dim != static_cast<std::uint32_t>(m.dim_))
    c.reader().fail(at, "averaged map state: dimension " + std::to_string(dim) +
                            ", the map it is restored into is " + std::to_string(m.dim_) + "D");
  expect_same_f64(c, "averaged map state", "spacing", m.opt_.spacing);
  expect_same_f64(c, "averaged map state", "min support", m.opt_.min_support);
  expect_same_f64(c, "averaged map state", "ridge", m.opt_.ridge);
  expect_same_f64(c, "averaged map state", "sweeps", double(m.opt_.sweeps));
  KernelMap k;
  k.dim = m.dim_;
  at = c.at();
  k.position = c.f64s("anchor positions");
  k.gamma = c.f64s("anchor widths");
  k.w_mean = c.f64s("weight means");
  k.w_var = c.f64s("weight variances");
  std::vector<double> sm = c.f64s("support-weighted logits"), s = c.f64s("supports");
  std::vector<double> sv = c.f64s("support-weighted variances"),
                      sg = c.f64s("support-weighted widths");
  const std::size_t n = k.gamma.size();
  if (k.position.size() != n * m.dim_ || k.w_mean.size() != n || k.w_var.size() != n ||
      sm.size() != n || s.size() != n || sv.size() != n || sg.size() != n)
    c.reader().fail(at, "averaged map state: the anchor arrays disagree in length (" +
                            std::to_string(n) + " widths)");
  k.validate(c.reader().path());
  for (std::size_t i = 0; i < n; ++i)
    if (!(s[i] > 0) || !std::isfinite(s[i]) || !std::isfinite(sm[i]) || !std::isfinite(sv[i]) ||
        !std::isfinite(sg[i]))
      c.reader().fail(at, "averaged map state: anchor " + std::to_string(i) + " has support " +
                              std::to_string(s[i]));
  AveragedMap cells(m.dim_, m.opt_);  // the new anchors' cells; m is untouched on failure
  for (std::size_t i = 0; i < n; ++i) {
    std::int64_t g[3] = {0, 0, 0};
    for (int d = 0; d < m.dim_; ++d) g[d] = m.cell(k.position[i * m.dim_ + d]);
    if (!cells.set_slot(g, std::uint32_t(i))) {
      std::int64_t other = -1;
      cells.slots_along_x(g, 1, &other);
      c.reader().fail(at, "averaged map state: anchors " + std::to_string(other) + " and " +
                              std::to_string(i) + " share a cell");
    }
  }
  m.map_ = std::move(k);
  m.sum_sm_ = std::move(sm);
  m.sum_s_ = std::move(s);
  m.sum_sv_ = std::move(sv);
  m.sum_sg_ = std::move(sg);
  m.blocks_ = std::move(cells.blocks_);
  m.block_slots_ = std::move(cells.block_slots_);
}

}  // namespace potmap::detail
