// A joint BHM's map file with its information form (include/potmap/learn/bhm_joint_merge.hpp):
// a version 2 .potmap whose section holds, little-endian,
//   u32 section layout (1)
//   the learner's options: u32 dim, f64 spacing, gamma, neighbour_phi, prior_var, u8 bias,
//     u32 em_iterations, f64 tau, cg_tolerance, u32 cg_max_iterations, solve_margin,
//     u8 seeds_yield, seeds_yield_fully, sums, u64 max_kernels; u8 bounded, f64 lo[3],
//     u64 kernels per axis[3]
//   the learner's state as a mapper checkpoint holds it (learn/bhm_joint_state.hpp), its
//     retired tiles, and its data fingerprints (u64 count, u64 each)
// Everything else of the file is the version 1 map (include/potmap/io/map_io.hpp).
#include <cmath>
#include <optional>
#include <string>

#include "io/container_cursor.hpp"
#include "io/map_io_native.hpp"
#include "learn/bhm_joint_merge_detail.hpp"
#include "learn/bhm_joint_state.hpp"
#include "potmap/error.hpp"
#include "potmap/learn/bhm_joint_merge.hpp"

namespace potmap {

namespace {

void put_options(detail::ContainerWriter& w, const JointBhm& m) {
  const JointBhmOptions& o = m.options();
  w.u32(static_cast<std::uint32_t>(detail::JointBhmMerge::dim(m)));
  for (double v : {o.spacing, o.gamma, o.neighbour_phi, o.prior_var}) w.f64(v);
  detail::put_u8(w, o.bias ? 1 : 0);
  w.u32(static_cast<std::uint32_t>(o.em_iterations));
  w.f64(o.tau);
  w.f64(o.cg_tolerance);
  w.u32(static_cast<std::uint32_t>(o.cg_max_iterations));
  w.u32(static_cast<std::uint32_t>(o.solve_margin));
  detail::put_u8(w, o.seeds_yield ? 1 : 0);
  detail::put_u8(w, o.seeds_yield_fully ? 1 : 0);
  detail::put_u8(w, static_cast<std::uint8_t>(o.sums));
  w.u64(o.max_kernels);
}

// The learner the section describes, empty, built as the saved one was (its state is read
// into it next). Options a constructor refuses are a corrupt file here.
JointBhm make_learner(detail::ContainerCursor& c) {
  const std::size_t at = c.at();
  JointBhmOptions o;
  const std::uint32_t dim = c.u32();
  o.spacing = c.f64();
  o.gamma = c.f64();
  o.neighbour_phi = c.f64();
  o.prior_var = c.f64();
  o.bias = c.u8() != 0;
  o.em_iterations = static_cast<int>(c.u32());
  o.tau = c.f64();
  o.cg_tolerance = c.f64();
  o.cg_max_iterations = static_cast<int>(c.u32());
  o.solve_margin = static_cast<int>(c.u32());
  o.seeds_yield = c.u8() != 0;
  o.seeds_yield_fully = c.u8() != 0;
  const std::uint8_t sums = c.u8();
  if (sums > 2) c.reader().fail(c.at() - 1, "joint BHM options: sums " + std::to_string(sums));
  o.sums = static_cast<JointBhmSums>(sums);
  o.max_kernels = static_cast<std::size_t>(c.u64());
  const bool bounded = c.u8() != 0;
  double lo[3], hi[3];
  for (double& v : lo) v = c.f64();
  for (int d = 0; d < 3; ++d) {
    const std::uint64_t n = c.u64();
    if (n < 1 || n > (std::uint64_t(1) << 26))
      c.reader().fail(c.at() - 8, "joint BHM options: " + std::to_string(n) + " kernels per axis");
    hi[d] = lo[d] + double(n - 1) * o.spacing;
  }
  try {
    return bounded ? JointBhm(static_cast<int>(dim), lo, hi, o)
                   : JointBhm(static_cast<int>(dim), o);
  } catch (const ArgumentError& e) {
    c.reader().fail(at, std::string("joint BHM options: ") + e.what());
  }
}

}  // namespace

void write_joint_bhm_map(const JointBhm& learner, const std::string& path,
                         const KernelMap* exported) {
  detail::check_potmap_name(path, "a joint BHM's information form");
  std::optional<KernelMap> own;
  if (!exported) exported = &own.emplace(learner.map());
  if (exported->dim != detail::JointBhmMerge::dim(learner))
    throw ArgumentError(path + ": the exported map is " + std::to_string(exported->dim) +
                        "D, the learner " + std::to_string(detail::JointBhmMerge::dim(learner)) +
                        "D");
  detail::write_map_native_with_section(*exported, path, [&](detail::ContainerWriter& w) {
    w.u32(detail::kJointBhmSection);
    put_options(w, learner);
    // The grid as the constructor took it (the state read back checks it too).
    detail::put_u8(w, learner.bounded() ? 1 : 0);
    double lo[3];
    std::int64_t n[3];
    detail::JointBhmMerge::grid(learner, lo, n);
    for (double v : lo) w.f64(v);
    for (std::int64_t v : n) w.u64(static_cast<std::uint64_t>(v));
    detail::JointBhmState::write(w, learner);
    detail::JointBhmState::write_retired(w, learner);
    detail::put_uints(w, learner.data_ids());
    // Forgetting: the half-life and the clocks (a file written before them ends here).
    w.f64(learner.options().half_life);
    detail::JointBhmState::write_clock(w, learner);
  });
}

std::optional<JointBhm> read_joint_bhm_information(const std::string& path) {
  const detail::ContainerReader r(path, detail::native_map_layout());
  const std::size_t at = detail::map_section_of(r);
  if (at == 0) return std::nullopt;
  detail::ContainerCursor c(r, at);
  const std::uint32_t layout = c.u32();
  if (layout == detail::kAveragedMapSection) return std::nullopt;
  if (layout != detail::kJointBhmSection)
    r.fail(at, "unknown information form layout " + std::to_string(layout) +
                   " (this build reads layout " + std::to_string(detail::kJointBhmSection) + ")");
  JointBhm m = make_learner(c);
  detail::JointBhmState::read(c, m);
  detail::JointBhmState::read_retired(c, m);
  for (std::uint64_t id : c.uints<std::uint64_t>("data fingerprints")) m.add_data_id(id);
  if (c.at() != r.payload_end()) {
    const std::size_t hat = c.at();
    const double half_life = c.f64();
    if (!(half_life >= 0) || !std::isfinite(half_life))
      r.fail(hat, "joint BHM options: half-life " + std::to_string(half_life) + " s");
    detail::JointBhmMerge::set_half_life(m, half_life);
  }
  detail::JointBhmState::read_clock(c, m);
  c.finish();
  return m;
}

}  // namespace potmap
