#include "learn/bhm_joint_state.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

namespace potmap::detail {

namespace {

// The values a restored learner must share with the saved one: those derived from the options
// and the constructor (the options themselves are the caller's to check).
void put_shape(ContainerWriter& w, int dim, bool bounded, const double lo[3],
               const std::int64_t n[3], double gamma, std::int64_t tile, std::int64_t slots) {
  w.u32(static_cast<std::uint32_t>(dim));
  put_u8(w, bounded ? 1 : 0);
  for (int d = 0; d < 3; ++d) w.f64(lo[d]);
  for (int d = 0; d < 3; ++d) w.u64(static_cast<std::uint64_t>(n[d]));
  w.f64(gamma);
  w.u64(static_cast<std::uint64_t>(tile));
  w.u64(static_cast<std::uint64_t>(slots));
}

template <class T>
void expect_same(ContainerCursor& c, std::size_t at, const char* what, T found, T have) {
  const bool same = std::memcmp(&found, &have, sizeof(T)) == 0;
  if (!same)
    c.reader().fail(at, std::string("joint BHM state: ") + what + " " + std::to_string(found) +
                            ", the learner it is restored into has " + std::to_string(have) +
                            " (saved with other options)");
}

template <class V>
void expect_size(ContainerCursor& c, std::size_t at, const char* what, const V& v,
                 std::size_t want) {
  if (v.size() != want)
    c.reader().fail(at, std::string("joint BHM state: ") + what + " holds " +
                            std::to_string(v.size()) + " values, " + std::to_string(want) +
                            " expected");
}

}  // namespace

void JointBhmState::write(ContainerWriter& w, const JointBhm& m, bool full_stencil) {
  put_shape(w, m.dim_, m.bounded_, m.lo_, m.n_, m.gamma_, m.tile_,
            full_stencil ? m.slots_ : m.half_slots_);
  std::vector<std::uint32_t> tiles;
  tiles.reserve(m.tiles_.size() * 30);
  for (const JointBhm::Tile& t : m.tiles_) {
    for (int d = 0; d < 3; ++d) tiles.push_back(static_cast<std::uint32_t>(t.coord[d]));
    for (int k = 0; k < 27; ++k) tiles.push_back(static_cast<std::uint32_t>(t.nb[k]));
  }
  put_uints(w, tiles);
  // var_ and tile_dirty_ are mutable caches: spell the pointer type out.
  std::vector<double> full;
  if (full_stencil) {
    // Every slot of the box, the mirrored half read from the kernel it couples to.
    const std::size_t cells = m.mean_.size(), slots = static_cast<std::size_t>(m.slots_);
    full.assign(cells * slots, 0.0);
    for (std::size_t a = 0; a < cells; ++a) {
      std::int64_t g[3];
      m.cell_of(static_cast<std::uint32_t>(a), g);
      for (std::size_t s = 0; s < slots; ++s) {
        std::int64_t rest = std::int64_t(s), o[3] = {0, 0, 0}, c[3] = {g[0], g[1], g[2]};
        for (int d = 0; d < m.dim_; ++d) {
          o[d] = rest % m.box_ - m.pad_;
          rest /= m.box_;
          c[d] += o[d];
        }
        const std::int64_t b = m.in_grid(c) ? m.find_cell(c, -1) : -1;
        full[a * slots + s] = m.coupling(std::int64_t(a), b, o);
      }
    }
  }
  const std::vector<double>* doubles[] = {full_stencil ? &full : &m.prec_, &m.eta_, &m.mean_,
                                          &m.bcoup_, &m.var_};
  for (const std::vector<double>* v : doubles) put_f64s(w, *v);
  const std::vector<std::uint8_t>* flags[] = {&m.touched_, &m.seeded_, &m.tile_dirty_};
  for (const std::vector<std::uint8_t>* v : flags) put_uints(w, *v);
  for (double x : {m.pbb_, m.etab_, m.meanb_}) w.f64(x);
  w.u64(m.stats_.samples);
  w.u64(m.stats_.active);
  w.u64(m.stats_.cg_iterations);
  w.f64(m.stats_.residual);
}

void JointBhmState::read(ContainerCursor& c, JointBhm& m) {
  std::size_t at = c.at();
  expect_same<std::uint32_t>(c, at, "dimension", c.u32(), static_cast<std::uint32_t>(m.dim_));
  at = c.at();
  expect_same<std::uint32_t>(c, at, "bounded", c.u8(), m.bounded_ ? 1u : 0u);
  for (int d = 0; d < 3; ++d) {
    at = c.at();
    expect_same<double>(c, at, "grid origin", c.f64(), m.lo_[d]);
  }
  for (int d = 0; d < 3; ++d) {
    at = c.at();
    expect_same<std::uint64_t>(c, at, "kernels per axis", c.u64(),
                               static_cast<std::uint64_t>(m.n_[d]));
  }
  at = c.at();
  expect_same<double>(c, at, "kernel width gamma", c.f64(), m.gamma_);
  at = c.at();
  expect_same<std::uint64_t>(c, at, "tile edge", c.u64(), static_cast<std::uint64_t>(m.tile_));
  at = c.at();
  // The half stencil, or the whole one of states saved before it.
  const std::uint64_t slots = c.u64();
  const bool full = slots == static_cast<std::uint64_t>(m.slots_);
  if (!full)
    expect_same<std::uint64_t>(c, at, "stencil slots", slots,
                               static_cast<std::uint64_t>(m.half_slots_));

  at = c.at();
  const std::vector<std::uint32_t> tiles = c.uints<std::uint32_t>("joint BHM tiles");
  if (tiles.size() % 30 != 0)
    c.reader().fail(at, "joint BHM state: " + std::to_string(tiles.size()) +
                            " tile values, not a multiple of 30");
  const std::size_t ntiles = tiles.size() / 30;
  const std::size_t cells = ntiles * static_cast<std::size_t>(m.tile_cells_);
  std::vector<JointBhm::Tile> restored(ntiles);
  std::unordered_map<std::uint64_t, std::uint32_t> index;
  for (std::size_t i = 0; i < ntiles; ++i) {
    JointBhm::Tile& t = restored[i];
    std::int64_t coord[3];
    for (int d = 0; d < 3; ++d)
      coord[d] = t.coord[d] = static_cast<std::int32_t>(tiles[i * 30 + d]);
    for (int k = 0; k < 27; ++k) {
      t.nb[k] = static_cast<std::int32_t>(tiles[i * 30 + 3 + k]);
      if (t.nb[k] < -1 || t.nb[k] >= std::int64_t(ntiles))
        c.reader().fail(at, "joint BHM state: tile " + std::to_string(i) + " names neighbour " +
                                std::to_string(t.nb[k]) + " of " + std::to_string(ntiles));
    }
    index.emplace(JointBhm::tile_key(coord), static_cast<std::uint32_t>(i));
  }
  std::vector<double>* doubles[] = {&m.prec_, &m.eta_, &m.mean_, &m.bcoup_, &m.var_};
  const char* names[] = {"precision", "eta", "means", "bias coupling", "variances"};
  const std::size_t want[] = {cells * static_cast<std::size_t>(slots), cells, cells, cells, cells};
  for (int k = 0; k < 5; ++k) {
    at = c.at();
    *doubles[k] = c.f64s(names[k]);
    expect_size(c, at, names[k], *doubles[k], want[k]);
  }
  if (full) {
    const auto hs = static_cast<std::size_t>(m.half_slots_);
    const std::vector<double> whole = std::move(m.prec_);
    m.prec_.assign(cells * hs, 0.0);
    for (std::size_t a = 0; a < cells; ++a) {
      const double* in = &whole[a * static_cast<std::size_t>(slots)];
      double* out = &m.prec_[a * hs];
      out[0] = in[m.slots_ / 2];
      for (const JointBhm::HalfRun& h : m.half_)
        std::copy(in + h.slot, in + h.slot + h.len, out + h.at);
    }
  }
  std::vector<std::uint8_t>* flags[] = {&m.touched_, &m.seeded_, &m.tile_dirty_};
  const char* flag_names[] = {"touched flags", "seeded flags", "dirty tiles"};
  const std::size_t flag_want[] = {cells, cells, ntiles};
  for (int k = 0; k < 3; ++k) {
    at = c.at();
    *flags[k] = c.uints<std::uint8_t>(flag_names[k]);
    expect_size(c, at, flag_names[k], *flags[k], flag_want[k]);
  }
  m.pbb_ = c.f64();
  m.etab_ = c.f64();
  m.meanb_ = c.f64();
  m.stats_.samples = c.u64();
  m.stats_.active = c.u64();
  m.stats_.cg_iterations = c.u64();
  m.stats_.residual = c.f64();
  m.tiles_ = std::move(restored);
  m.tile_index_ = std::move(index);
  m.tile_clock_.assign(ntiles, m.clock_);  // read_clock() may say otherwise
  for (int k = 0; k < 4; ++k) {            // the tiles span_tiles() last found were m's old ones
    m.recent_key_[k] = ~0ull;
    m.recent_id_[k] = -1;
  }
  // Scratch: update() leaves mark_ zero and the solver's p zero outside its rows.
  m.mark_.assign(cells, 0);
  m.scratch_ = JointBhm::Scratch();
}

void JointBhmState::write_retired(ContainerWriter& w, const JointBhm& m) {
  w.u64(m.retired_.size());
  for (const JointBhm::RetiredTile& r : m.retired_) {
    for (int d = 0; d < 3; ++d) w.u32(static_cast<std::uint32_t>(r.coord[d]));
    w.f32s(r.mean);
    w.f32s(r.var);
  }
}

void JointBhmState::read_retired(ContainerCursor& c, JointBhm& m) {
  const std::size_t at = c.at();
  const std::size_t cells = static_cast<std::size_t>(m.tile_cells_);
  const std::size_t n = c.count(12 + 8 * cells, "retired tiles");
  std::vector<JointBhm::RetiredTile> tiles(n);
  std::unordered_map<std::uint64_t, std::uint32_t> index;
  for (std::size_t t = 0; t < n; ++t) {
    JointBhm::RetiredTile& r = tiles[t];
    std::int64_t k[3];
    for (int d = 0; d < 3; ++d) k[d] = r.coord[d] = static_cast<std::int32_t>(c.u32());
    r.mean = c.f32s(cells, "retired means");
    r.var = c.f32s(cells, "retired variances");
    if (m.find_tile(k) >= 0 || !index.emplace(JointBhm::tile_key(k), std::uint32_t(t)).second)
      c.reader().fail(at, "joint BHM state: retired tile " + std::to_string(t) +
                              " is also stored or retired twice");
  }
  m.retired_ = std::move(tiles);
  m.retired_index_ = std::move(index);
}

void JointBhmState::write_data_ids(ContainerWriter& w, const JointBhm& m) {
  put_uints(w, m.data_ids_);
}

void JointBhmState::read_data_ids(ContainerCursor& c, JointBhm& m) {
  if (c.at() == c.reader().payload_end()) return;
  m.data_ids_ = c.uints<std::uint64_t>("data fingerprints");
}

void JointBhmState::write_clock(ContainerWriter& w, const JointBhm& m) {
  w.f64(m.clock_);
  put_u8(w, m.clock_set_ ? 1 : 0);
  put_f64s(w, m.tile_clock_);
  std::vector<double> retired;
  retired.reserve(m.retired_.size());
  for (const JointBhm::RetiredTile& r : m.retired_) retired.push_back(r.clock);
  put_f64s(w, retired);
}

void JointBhmState::read_clock(ContainerCursor& c, JointBhm& m) {
  if (c.at() == c.reader().payload_end()) {
    m.clock_ = 0;
    m.clock_set_ = false;
    m.tile_clock_.assign(m.tiles_.size(), 0.0);
    for (JointBhm::RetiredTile& r : m.retired_) r.clock = 0;
    return;
  }
  std::size_t at = c.at();
  const double clock = c.f64();
  if (!std::isfinite(clock)) c.reader().fail(at, "joint BHM state: clock " + std::to_string(clock));
  const bool set = c.u8() != 0;
  at = c.at();
  std::vector<double> tiles = c.f64s("tile clocks");
  expect_size(c, at, "tile clocks", tiles, m.tiles_.size());
  at = c.at();
  const std::vector<double> retired = c.f64s("retired tile clocks");
  expect_size(c, at, "retired tile clocks", retired, m.retired_.size());
  for (double t : tiles)
    if (!(t <= clock))
      c.reader().fail(at, "joint BHM state: a tile clock " + std::to_string(t) +
                              " past the clock " + std::to_string(clock));
  m.clock_ = clock;
  m.clock_set_ = set;
  m.tile_clock_ = std::move(tiles);
  for (std::size_t t = 0; t < retired.size(); ++t) m.retired_[t].clock = retired[t];
}

}  // namespace potmap::detail
