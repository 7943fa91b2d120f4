// The joint BHM over a 3D drive, a keyframe at a time.
#include "potmap/mapping/drive_mapper.hpp"

#include <chrono>
#include <cmath>
#include <limits>

#include "potmap/data/keyframe_samples.hpp"
#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"

namespace potmap {

namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

JointBhmOptions drive_bhm_options() {
  JointBhmOptions o;
  o.spacing = 1.0;
  o.tau = 4.5;
  o.solve_margin = 1;
  o.em_iterations = 2;
  o.cg_tolerance = 1e-4;
  return o;
}

PotOptions drive_pot_options() {
  PotOptions p;
  p.ranking = PotRanking::indexed;
  p.rotations = evenly_spaced_rotations(8);
  p.placement = PotPlacement::barycentric;
  p.displacement_variance = 0.25;
  p.wall_clearance = 1.0;
  p.transport_points = 500;
  return p;
}

DriveMapper::DriveMapper(const DriveMapperOptions& options)
    : o_(options), learner_(3, options.bhm) {
  if (!(o_.range_cut > 0) || !std::isfinite(o_.range_cut))
    throw ArgumentError("drive mapper: range cut must be positive, got " +
                        std::to_string(o_.range_cut));
  if (!(o_.voxel >= 0) || !std::isfinite(o_.voxel))
    throw ArgumentError("drive mapper: voxel must be 0 or positive, got " +
                        std::to_string(o_.voxel));
  if (o_.test_stride == 0) throw ArgumentError("drive mapper: test_stride must be at least 1");
  if (o_.dictionary && o_.dictionary->dim != 3)
    throw ArgumentError("drive mapper: the dictionary is " + std::to_string(o_.dictionary->dim) +
                        "D, a drive needs 3D atoms");
  // The indexed ranking's index of the atoms, built once here: a transfer without it builds
  // one from the whole dictionary (270 ms of a 290 ms transfer on hku-1 with the built-in one).
  if (o_.dictionary && o_.pot.ranking == PotRanking::indexed && !o_.pot.index)
    o_.pot.index = std::make_shared<const AtomIndex>(*o_.dictionary);
  if (o_.transfer_every == 0)
    throw ArgumentError("drive mapper: transfer_every must be at least 1");
  if (!(o_.seed_min_variance >= 0) || !std::isfinite(o_.seed_min_variance))
    throw ArgumentError("drive mapper: seed_min_variance must be >= 0, got " +
                        std::to_string(o_.seed_min_variance));
  test_.dim = 3;
}

KernelMap DriveMapper::map(Context* ctx) const {
  KernelMap m = learner_.map(ctx, 1e-6);
  m.cutoff_tau = learner_.options().tau;
  return m;
}

KeyframeStats DriveMapper::add(const Scan& keyframe, std::int64_t index, Context* ctx) {
  if (keyframe.dim != 3)
    throw ArgumentError("drive mapper: keyframe " + std::to_string(index) + " is " +
                        std::to_string(keyframe.dim) + "D, not 3D");
  KeyframeStats st;
  const auto t0 = std::chrono::steady_clock::now();
  const Scan cut = limit_range(keyframe, o_.range_cut);
  LabelledSplit split;
  LabelledPoints train;
  if (o_.voxel > 0) {
    KeyframeSamples ks = gather_keyframe(cut, index, o_.labels, o_.voxel, ctx);
    st.samples = ks.samples;
    st.on_device = ks.on_device;
    train = std::move(ks.train);
    split.test = std::move(ks.test);
  } else {
    label_scan(cut, index, o_.labels, split);
    st.samples = split.train.size();
    train = std::move(split.train);
  }
  st.gathered = train.size();
  for (std::size_t i = 0; i < split.test.size(); i += o_.test_stride) {
    for (int d = 0; d < 3; ++d) test_.position.push_back(split.test.position[3 * i + d]);
    test_.label.push_back(split.test.label[i]);
    test_.scan.push_back(index);
    ++st.held_out;
  }
  st.label_ms = ms_since(t0);
  if (o_.lookahead && keyframes_ > 0) {
    const auto ta = std::chrono::steady_clock::now();
    look_ahead(test_.size() - st.held_out, ctx);
    st.lookahead_ms = ms_since(ta);
  }
  // The keyframe's time is the learner's clock (forgetting: bhm.half_life).
  learner_.set_time(keyframe.timestamp);
  if (o_.dictionary && !train.empty() && keyframes_ % o_.transfer_every == 0) {
    const auto t2 = std::chrono::steady_clock::now();
    const ScanTransfer t = transfer_scan(ctx, *o_.dictionary, train, keyframe.origin(),
                                         scan_heading(keyframe), index, o_.pot);
    st.seeded = learner_.seed_unreached(t.map, o_.seed_min_variance);
    st.transfer_ms = ms_since(t2);
  }
  const auto t1 = std::chrono::steady_clock::now();
  learner_.update(train, ctx);
  st.sums_on_device = learner_.last_stats().sums_on_device;
  const double radius = o_.retire_radius < 0 ? o_.range_cut + 16 : o_.retire_radius;
  const auto at = keyframe.origin();
  st.retired = learner_.retire_far(at.data(), radius, ctx);
  st.update_ms = ms_since(t1);
  ++keyframes_;
  st.memory_bytes = memory_bytes();
  return st;
}

void DriveMapper::look_ahead(std::size_t first, Context* ctx) {
  const std::size_t n = test_.size() - first;
  if (n == 0) return;
  const double* at = &test_.position[3 * first];
  std::vector<double> mean(n), var(n);
  learner_.predict(at, n, mean.data(), var.data(), ctx);
  const std::size_t old = ahead_.size();
  ahead_.beyond.resize(old + n);
  learner_.reached(at, n, &ahead_.beyond[old]);
  for (std::size_t i = 0; i < n; ++i) {
    ahead_.beyond[old + i] ^= 1;
    ahead_.prob.push_back(static_cast<float>(probit_probability(mean[i], var[i])));
    ahead_.label.push_back(test_.label[first + i]);
  }
}

void lookahead_scores(const LookAhead& ahead, Scores& all, Scores& beyond) {
  std::vector<float> p;
  std::vector<std::uint8_t> y;
  for (std::size_t i = 0; i < ahead.size(); ++i)
    if (ahead.beyond[i]) {
      p.push_back(ahead.prob[i]);
      y.push_back(ahead.label[i]);
    }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Scores none{nan, nan, nan, 0};
  all = ahead.size() ? score(ahead.prob, ahead.label) : none;
  beyond = p.empty() ? none : score(p, y);
}

std::size_t DriveMapper::memory_bytes() const {
  return learner_.memory_bytes() + test_.position.capacity() * sizeof(double) +
         test_.label.capacity() + test_.scan.capacity() * sizeof(std::int64_t) +
         ahead_.prob.capacity() * sizeof(float) + ahead_.label.capacity() +
         ahead_.beyond.capacity();
}

}  // namespace potmap
