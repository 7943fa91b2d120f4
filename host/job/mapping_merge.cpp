#include "mapping_merge.hpp"

#include <chrono>
#include <cstdio>

#include "job_text.hpp"
#include "potmap/error.hpp"
#include "potmap/mapping/map_files.hpp"
#include "rank_bytes.hpp"
#include "rank_maps.hpp"

namespace potmap::job {

namespace {

void put_totals(RankBytesOut& o, const MapRunTotals& t) {
  o.put(t.inst_prob);
  o.put(t.labels);
  o.put(t.test);
  o.put(t.timing);
  o.put(t.wall_ms);
  o.put(t.max_wall_ms);
  o.put(std::uint64_t(t.kernels));
  o.put(std::uint64_t(t.scans));
}

MapRunTotals get_totals(RankBytesIn& in) {
  MapRunTotals t;
  in.get(t.inst_prob);
  in.get(t.labels);
  in.get(t.test);
  in.get(t.timing);
  in.get(t.wall_ms);
  in.get(t.max_wall_ms);
  std::uint64_t kernels = 0, scans = 0;
  in.get(kernels);
  in.get(scans);
  t.kernels = std::size_t(kernels);
  t.scans = std::size_t(scans);
  return t;
}

// What a rank sends: its part, its time, its totals and (not rank 0) its map's bytes.
std::string pack_log_part(const RankPart& part, const MapJobResult& r, bool with_map) {
  RankBytesOut o;
  o.put(std::uint64_t(part.begin));
  o.put(std::uint64_t(part.end));
  o.put(r.total_seconds);
  put_totals(o, r.totals);
  o.put(with_map ? potmap_bytes([&](const std::string& p) { write_mapper_map(*r.mapper, p); })
                 : std::string());
  return std::move(o.bytes());
}

// Rank 0's map and the others' received ones, merged as `potmap merge` merges their files.
void merge_maps(const Mapper& own, std::vector<ReceivedMap>& others, MergedOverall& m) {
  if (const RepotMap* repot = own.repot()) {
    std::vector<const JointBhm*> maps = {&repot->learner()};
    JointBhmMergeOptions o;
    o.names = {"rank 0's map"};
    for (std::size_t i = 0; i < others.size(); ++i) {
      if (!others[i].joint)
        throw InputError("rank " + std::to_string(i + 1) +
                         " sent POT's averaged map, rank 0 has RePOT's");
      maps.push_back(&*others[i].joint);
      o.names.push_back("rank " + std::to_string(i + 1) + "'s map");
    }
    m.joint = merge_joint_bhm(maps, o);
    m.map = m.joint->map();
    return;
  }
  m.averaged = *own.averaged();
  for (std::size_t i = 0; i < others.size(); ++i) {
    if (!others[i].averaged)
      throw InputError("rank " + std::to_string(i + 1) +
                       " sent a joint BHM map, rank 0 has POT's averaged map");
    m.averaged->add_map(*others[i].averaged);
  }
  m.map = m.averaged->map();
}

}  // namespace

void check_rank_mergeable(const MapperOptions& o) {
  if (!persistent_refine(o) && !o.average_overall)
    throw ArgumentError(
        "mapping: POT's summed kernels (--method pot --preset paper) keep nothing to merge: map "
        "with them on one process, or use the default preset under mpirun");
}

bool merge_rank_maps(JobRanks& ranks, Context* ctx, const RankPart& part, MapJobResult& r,
                     const std::function<void(const std::string&)>& note) {
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<std::string> all = ranks.gather(pack_log_part(part, r, ranks.rank() != 0));
  if (ranks.rank() != 0) return false;
  const double waited = seconds_since(t0);
  auto merged = std::make_shared<MergedOverall>();
  MapRunTotals totals = std::move(r.totals);
  std::vector<ReceivedMap> others;
  nlohmann::json parts = nlohmann::json::array();
  for (std::size_t i = 0; i < all.size(); ++i) {
    const std::string from = "rank " + std::to_string(i);
    RankBytesIn in(all[i], from);
    std::uint64_t begin = 0, end = 0;
    double seconds = 0;
    in.get(begin);
    in.get(end);
    in.get(seconds);
    MapRunTotals t = get_totals(in);
    std::string map;
    in.get(map);
    all[i].clear();
    parts.push_back(
        {{"rank", i}, {"first_scan", begin}, {"scans", end - begin}, {"seconds", seconds}});
    if (i == 0) continue;
    add_totals(totals, t);
    others.push_back(read_potmap_bytes(map, from));
  }
  const auto t_merge = std::chrono::steady_clock::now();
  merge_maps(*r.mapper, others, *merged);
  const double merge_s = seconds_since(t_merge);
  if (note)
    note(
        format("merged the maps of %d ranks: %zu kernels in %.2f s (waited %.2f s for the "
               "other ranks)",
               ranks.size(), merged->kernels(), merge_s, waited));
  merged->record = {{"ranks", ranks.size()},
                    {"parts", parts},
                    {"wait_seconds", waited},
                    {"merge_seconds", merge_s}};
  r.merged = merged;
  summarise(r, totals, ctx);
  r.totals = std::move(totals);
  r.total_seconds += seconds_since(t0);
  return true;
}

}  // namespace potmap::job
