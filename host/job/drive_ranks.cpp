#include "drive_ranks.hpp"

#include <chrono>
#include <cstdio>
#include <functional>

#include "job_text.hpp"
#include "potmap/error.hpp"
#include "potmap/learn/bhm_joint_merge.hpp"
#include "rank_bytes.hpp"
#include "rank_maps.hpp"

namespace potmap::job {

namespace {

void put_run(RankBytesOut& o, const DriveRun& r) {
  o.put(std::uint64_t(r.keyframes));
  o.put(r.label_ms);
  o.put(r.transfer_ms);
  o.put(r.update_ms);
  o.put(r.max_ms);
  o.put(std::uint64_t(r.peak_bytes));
  o.put(r.positions);
  o.put(r.memory_mb);
  o.put(r.keyframe_ms);
}

// `r`'s keyframes followed by those in `in`.
void add_run(RankBytesIn& in, DriveRun& r) {
  std::uint64_t keyframes = 0, peak = 0;
  double label = 0, transfer = 0, update = 0, max_ms = 0;
  std::vector<double> positions, memory, ms;
  in.get(keyframes);
  in.get(label);
  in.get(transfer);
  in.get(update);
  in.get(max_ms);
  in.get(peak);
  in.get(positions);
  in.get(memory);
  in.get(ms);
  r.keyframes += std::size_t(keyframes);
  r.label_ms += label;
  r.transfer_ms += transfer;
  r.update_ms += update;
  r.max_ms = std::max(r.max_ms, max_ms);
  r.peak_bytes = std::max(r.peak_bytes, std::size_t(peak));
  r.positions.insert(r.positions.end(), positions.begin(), positions.end());
  r.memory_mb.insert(r.memory_mb.end(), memory.begin(), memory.end());
  r.keyframe_ms.insert(r.keyframe_ms.end(), ms.begin(), ms.end());
}

void add_points(LabelledPoints& into, const LabelledPoints& p) {
  into.position.insert(into.position.end(), p.position.begin(), p.position.end());
  into.label.insert(into.label.end(), p.label.begin(), p.label.end());
  into.scan.insert(into.scan.end(), p.scan.begin(), p.scan.end());
}

// What a rank other than 0 sends: its part, its run, its held-out samples and its map.
std::string pack_drive_part(const RankPart& part, const DriveMapper& mapper, const DriveRun& run) {
  RankBytesOut o;
  o.put(std::uint64_t(part.begin));
  o.put(std::uint64_t(part.end));
  put_run(o, run);
  o.put(mapper.held_out());
  // Only the information form travels: rank 0 solves the merged map's means and variances
  // itself, so this rank's own (a solve over its kernels) would be computed for nothing.
  KernelMap unsolved;
  unsolved.dim = 3;
  o.put(potmap_bytes(
      [&](const std::string& p) { write_joint_bhm_map(mapper.learner(), p, &unsolved); }));
  return std::move(o.bytes());
}

}  // namespace

std::optional<DriveMerged> merge_drive_ranks(JobRanks& ranks, const RankPart& part,
                                             const DriveMapper& mapper, const DriveRun& run,
                                             const std::function<void(const std::string&)>& note) {
  const auto t0 = std::chrono::steady_clock::now();
  if (ranks.rank() != 0) {
    ranks.gather(pack_drive_part(part, mapper, run));
    return std::nullopt;
  }
  std::vector<std::string> all = ranks.gather(std::string());
  const double waited = seconds_since(t0);
  DriveMerged m;
  m.run = run;
  m.held_out = mapper.held_out();
  std::vector<JointBhm> others;
  JointBhmMergeOptions o;
  o.names = {"rank 0's map"};
  nlohmann::json parts = {
      {{"rank", 0}, {"first_keyframe", part.begin}, {"keyframes", part.size()}}};
  for (std::size_t i = 1; i < all.size(); ++i) {
    const std::string from = "rank " + std::to_string(i);
    RankBytesIn in(all[i], from);
    std::uint64_t begin = 0, end = 0;
    in.get(begin);
    in.get(end);
    add_run(in, m.run);
    LabelledPoints held;
    in.get(held);
    add_points(m.held_out, held);
    std::string map;
    in.get(map);
    ReceivedMap got = read_potmap_bytes(map, from);
    if (!got.joint) throw InputError(from + " sent POT's averaged map, not a joint BHM's");
    others.push_back(std::move(*got.joint));
    o.names.push_back(from + "'s map");
    parts.push_back({{"rank", i}, {"first_keyframe", begin}, {"keyframes", end - begin}});
    all[i] = std::string();
  }
  const auto t_merge = std::chrono::steady_clock::now();
  std::vector<const JointBhm*> maps = {&mapper.learner()};
  for (const JointBhm& j : others) maps.push_back(&j);
  m.joint = merge_joint_bhm(maps, o);
  const double merge_s = seconds_since(t_merge);
  const JointBhmStats solved = m.joint->last_stats();  // the merge's solve (map() adds its own)
  const auto t_export = std::chrono::steady_clock::now();
  m.map = m.joint->map();
  const double export_s = seconds_since(t_export);
  if (note)
    note(
        format("merged the maps of %d ranks: %zu kernels in %.2f s (%zu CG iterations), the "
               "merged map in %.2f s (waited %.2f s for the other ranks)",
               ranks.size(), m.joint->size(), merge_s, solved.cg_iterations, export_s, waited));
  m.record = {{"ranks", ranks.size()},
              {"parts", parts},
              {"wait_seconds", waited},
              {"merge_seconds", merge_s},
              {"merge_cg_iterations", solved.cg_iterations},
              {"export_seconds", export_s}};
  return m;
}

}  // namespace potmap::job
