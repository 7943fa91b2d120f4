// DriveMapper::save_state / load_state (include/potmap/mapping/drive_mapper.hpp).
//
// A container (io/container.hpp) "POTDRV\r\n", version 1: offset 12 u32 reserved (0), offset 16
// u64 file size; then the caller's extra bytes, a fingerprint of the options that change the
// map (u64), the keyframe count, the held-out samples (positions, labels, keyframe indices) and
// the learner (learn/bhm_joint_state.hpp) with its retired tiles and, last, its data
// fingerprints and its clock, and the look-ahead (probabilities, labels, reach flags; states
// saved before any of these end without them and read as before).
#include <cstring>

#include "io/container_cursor.hpp"
#include "io/file_util.hpp"
#include "learn/bhm_joint_state.hpp"
#include "potmap/error.hpp"
#include "potmap/mapping/drive_mapper.hpp"
#include "potmap/pot/fingerprint.hpp"
#include "runtime/hash.hpp"

namespace potmap {

namespace {

constexpr detail::ContainerLayout kLayout{"POTDRV\r\n", "a potmap drive mapper state", 1, 24, 16};

std::uint64_t options_fingerprint(const DriveMapperOptions& o) {
  const JointBhmOptions& b = o.bhm;
  const double v[] = {o.retire_radius,
                      o.range_cut,
                      o.labels.free_per_metre,
                      double(o.labels.max_free_per_beam),
                      o.labels.holdout_fraction,
                      double(o.labels.seed),
                      o.voxel,
                      double(o.test_stride),
                      b.spacing,
                      b.gamma,
                      b.neighbour_phi,
                      b.prior_var,
                      double(b.bias),
                      double(b.em_iterations),
                      b.tau,
                      b.cg_tolerance,
                      double(b.cg_max_iterations),
                      double(b.solve_margin)};
  std::string bytes(sizeof v, '\0');
  std::memcpy(&bytes[0], v, sizeof v);
  if (o.dictionary) {
    // RePOT: the atoms and what the transfer makes of them (a BHM-only state's bytes as before).
    const PotOptions& p = o.pot;
    const std::uint64_t atoms = fingerprint(*o.dictionary);
    bytes.append(reinterpret_cast<const char*>(&atoms), sizeof atoms);
    const double r[] = {o.seed_min_variance,        double(o.transfer_every),
                        double(p.sectors),          p.max_range,
                        double(p.rotations.size()), double(p.ranking),
                        double(p.placement),        p.displacement_variance,
                        p.wall_clearance,           double(p.index_neighbours),
                        double(p.fine_candidates),  double(p.transport_points)};
    bytes.append(reinterpret_cast<const char*>(r), sizeof r);
  }
  return detail::fnv1a64(bytes);
}

}  // namespace

void DriveMapper::save_state(const std::string& path, const std::string& extra) const {
  detail::write_file_atomically(path, state_bytes(extra));
}

std::string DriveMapper::state_bytes(const std::string& extra) const {
  detail::ContainerWriter w(kLayout);
  w.u32(0);
  w.u64(0);  // the file size: filled in by finish()
  detail::put_text(w, extra);
  w.u64(options_fingerprint(o_));
  w.u64(keyframes_);
  w.u64(test_.position.size());
  w.f64s(test_.position);
  detail::put_uints(w, test_.label);
  std::vector<std::uint64_t> scans(test_.scan.begin(), test_.scan.end());
  detail::put_uints(w, scans);
  detail::JointBhmState::write(w, learner_);
  detail::JointBhmState::write_retired(w, learner_);
  detail::JointBhmState::write_data_ids(w, learner_);
  detail::JointBhmState::write_clock(w, learner_);
  // The look-ahead last (states saved before it end without it and read as none).
  std::vector<double> prob(ahead_.prob.begin(), ahead_.prob.end());
  w.u64(prob.size());
  w.f64s(prob);
  detail::put_uints(w, ahead_.label);
  detail::put_uints(w, ahead_.beyond);
  return w.finish_bytes();
}

std::string DriveMapper::state_extra(const std::string& path) {
  const detail::ContainerReader r(path, kLayout);
  r.verify();
  detail::ContainerCursor c(r, kLayout.header_bytes);
  return c.text("extra bytes");
}

std::string DriveMapper::load_state(const std::string& path) {
  const detail::ContainerReader r(path, kLayout);
  r.verify();
  detail::ContainerCursor c(r, kLayout.header_bytes);
  std::string extra = c.text("extra bytes");
  const std::size_t fp_at = c.at();
  const std::uint64_t fp = c.u64();
  if (fp != options_fingerprint(o_))
    r.fail(fp_at, "saved with other drive mapper options (fingerprint " + detail::hex64(fp) +
                      ", this mapper's " + detail::hex64(options_fingerprint(o_)) + ")");
  const std::uint64_t keyframes = c.u64();
  LabelledPoints test;
  test.dim = 3;
  test.position = c.f64s("held-out positions");
  test.label = c.uints<std::uint8_t>("held-out labels");
  const std::vector<std::uint64_t> scans = c.uints<std::uint64_t>("held-out keyframes");
  if (test.position.size() != 3 * test.label.size() || scans.size() != test.label.size())
    r.fail(fp_at + 16, "held-out samples: " + std::to_string(test.position.size()) +
                           " coordinates, " + std::to_string(test.label.size()) + " labels, " +
                           std::to_string(scans.size()) + " keyframe indices");
  test.scan.assign(scans.begin(), scans.end());
  JointBhm learner(3, o_.bhm);
  detail::JointBhmState::read(c, learner);
  detail::JointBhmState::read_retired(c, learner);
  detail::JointBhmState::read_data_ids(c, learner);
  detail::JointBhmState::read_clock(c, learner);
  LookAhead ahead;
  if (c.at() != r.payload_end()) {
    const std::size_t ahead_at = c.at();
    const std::vector<double> prob = c.f64s("look-ahead probabilities");
    ahead.label = c.uints<std::uint8_t>("look-ahead labels");
    ahead.beyond = c.uints<std::uint8_t>("look-ahead reach");
    if (ahead.label.size() != prob.size() || ahead.beyond.size() != prob.size())
      r.fail(ahead_at, "look-ahead: " + std::to_string(prob.size()) + " probabilities, " +
                           std::to_string(ahead.label.size()) + " labels, " +
                           std::to_string(ahead.beyond.size()) + " reach flags");
    ahead.prob.assign(prob.begin(), prob.end());
  }
  c.finish();
  learner_ = std::move(learner);
  test_ = std::move(test);
  ahead_ = std::move(ahead);
  keyframes_ = std::size_t(keyframes);
  return extra;
}

}  // namespace potmap
