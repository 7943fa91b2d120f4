// Mapper::save_state / load_state (include/potmap/pot/mapper.hpp): the state file.
//
// A container (io/container.hpp) "POTMST\r\n", version 1:
//   offset 12  u32  dimension           offset 16  u64  file size
// then, read in order (io/container_cursor.hpp): the caller's extra bytes (first, so that a
// caller can check its own identity before the mapper's), the dictionary's and the options'
// fingerprints (u64 each), the scan count, the chosen atoms of the two last scans, the last
// merge's counters, POT's overall map (pot/overall_map_state.hpp), a byte saying whether
// the persistent RePOT learner follows (learn/bhm_joint_state.hpp), and, only when
// MapperOptions::average_overall is on, the averaged overall map (pot/averaged_map_state.hpp;
// states without it read as before), and with the persistent learner its data fingerprints
// (last: states saved before them read as before, without them).
#include <string>

#include "io/container_cursor.hpp"
#include "learn/bhm_joint_state.hpp"
#include "pot/averaged_map_state.hpp"
#include "pot/overall_map_state.hpp"
#include "potmap/error.hpp"
#include "potmap/pot/fingerprint.hpp"
#include "potmap/pot/mapper.hpp"
#include "runtime/hash.hpp"

namespace potmap {

namespace detail {

namespace {

constexpr ContainerLayout kLayout{"POTMST\r\n", "a potmap mapper state", 1, 24, 16};

void put_atoms(ContainerWriter& w, const std::vector<long>& atoms) {
  std::vector<std::uint64_t> v(atoms.begin(), atoms.end());
  put_uints(w, v);
}

std::vector<long> get_atoms(ContainerCursor& c) {
  const std::vector<std::uint64_t> v = c.uints<std::uint64_t>("chosen atoms");
  std::vector<long> out;
  out.reserve(v.size());
  for (std::uint64_t a : v) out.push_back(static_cast<long>(static_cast<std::int64_t>(a)));
  return out;
}

}  // namespace

struct MapperState {
  static void save(const Mapper& m, const std::string& path, const std::string& extra) {
    ContainerWriter w(kLayout);
    w.u32(static_cast<std::uint32_t>(m.dict_->dim));
    w.u64(0);  // the file size: filled in by finish()
    put_text(w, extra);
    w.u64(fingerprint(*m.dict_));
    w.u64(fingerprint(m.options_, m.overall_.options()));
    w.u64(m.scans_);
    put_atoms(w, m.warm_[0]);
    put_atoms(w, m.warm_[1]);
    const MapperMerge& g = m.merge_;
    for (std::size_t v : {g.stats.added, g.stats.merged, g.stats.retired, g.stats.fused, g.seeded})
      w.u64(v);
    w.f64(g.merge_ms);
    OverallMapState::write(w, m.overall_);
    put_u8(w, m.repot_ ? 1 : 0);
    if (m.repot_) JointBhmState::write(w, m.repot_->learner_);
    if (m.averaged_) AveragedMapState::write(w, *m.averaged_);
    if (m.repot_) {
      JointBhmState::write_data_ids(w, m.repot_->learner_);
      JointBhmState::write_clock(w, m.repot_->learner_);
    }
    w.finish(path);
  }

  static std::string extra(const std::string& path) {
    const ContainerReader r(path, kLayout);
    r.verify();
    ContainerCursor c(r, kLayout.header_bytes);
    return c.text("extra bytes");
  }

  static std::string load(Mapper& m, const std::string& path) {
    const ContainerReader r(path, kLayout);
    r.verify();
    const std::uint32_t dim = r.u32(12);
    if (dim != static_cast<std::uint32_t>(m.dict_->dim))
      r.fail(12, "a " + std::to_string(dim) + "D mapper state, the mapper is " +
                     std::to_string(m.dict_->dim) + "D");
    ContainerCursor c(r, kLayout.header_bytes);
    std::string extra = c.text("extra bytes");
    const std::size_t fp_at = c.at();
    const std::uint64_t dict_fp = c.u64(), options_fp = c.u64();
    if (dict_fp != fingerprint(*m.dict_))
      r.fail(fp_at, "saved with another dictionary (fingerprint " + hex64(dict_fp) +
                        ", this mapper's dictionary " + hex64(fingerprint(*m.dict_)) + ")");
    const std::uint64_t have = fingerprint(m.options_, m.overall_.options());
    if (options_fp != have)
      r.fail(fp_at + 8, "saved with other mapper options (fingerprint " + hex64(options_fp) +
                            ", this mapper's " + hex64(have) + ")");
    const std::uint64_t scans = c.u64();
    std::vector<long> warm0 = get_atoms(c), warm1 = get_atoms(c);
    MapperMerge g;
    g.stats.added = c.u64();
    g.stats.merged = c.u64();
    g.stats.retired = c.u64();
    g.stats.fused = c.u64();
    g.seeded = c.u64();
    g.merge_ms = c.f64();
    OverallMap overall(m.dict_->dim, m.overall_.options());
    OverallMapState::read(c, overall);
    const std::size_t at = c.at();
    const bool has_repot = c.u8() != 0;
    if (has_repot != m.repot_.has_value())
      r.fail(at, has_repot ? "a RePOT state with a persistent map, the mapper has none"
                           : "a state without RePOT's persistent map, the mapper has one");
    std::optional<RepotMap> repot;
    if (has_repot) {
      repot.emplace(m.dict_->dim, m.options_);
      JointBhmState::read(c, repot->learner_);
    }
    std::optional<AveragedMap> averaged;
    if (m.averaged_) {
      averaged.emplace(m.dict_->dim, m.options_.averaged);
      AveragedMapState::read(c, *averaged);
    }
    if (repot) {
      JointBhmState::read_data_ids(c, repot->learner_);
      JointBhmState::read_clock(c, repot->learner_);
    }
    c.finish();
    // Everything read: now the mapper changes, all at once.
    m.overall_ = std::move(overall);
    m.repot_ = std::move(repot);
    m.averaged_ = std::move(averaged);
    m.scans_ = static_cast<std::size_t>(scans);
    m.warm_[0] = std::move(warm0);
    m.warm_[1] = std::move(warm1);
    m.merge_ = g;
    m.last_ = MappedScan();
    m.last_.index = m.scans_ > 0 ? m.scans_ - 1 : 0;
    m.last_.transfer.map.dim = m.last_.test.dim = m.last_.train.dim = m.dict_->dim;
    return extra;
  }
};

}  // namespace detail

void Mapper::save_state(const std::string& path, const std::string& extra) const {
  settle();
  detail::MapperState::save(*this, path, extra);
}

std::string Mapper::load_state(const std::string& path) {
  settle();
  return detail::MapperState::load(*this, path);
}

std::string Mapper::state_extra(const std::string& path) {
  return detail::MapperState::extra(path);
}

}  // namespace potmap
