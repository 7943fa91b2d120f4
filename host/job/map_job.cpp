#include "potmap/job/map_job.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "job_text.hpp"
#include "map_checkpoint.hpp"
#include "mapping_merge.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/mapping/drive_mapper.hpp"
#include "potmap/mapping/map_files.hpp"

namespace potmap::job {

namespace {

nlohmann::json scores_json(const Scores& s) {
  return {{"acc", s.acc}, {"auc", s.auc}, {"nll", s.nll}, {"points", s.n}};
}

// The shared dictionary a Mapper wants, without a copy: run_map_job's caller owns it.
std::shared_ptr<const Dictionary> borrowed(const Dictionary& dict) {
  return std::shared_ptr<const Dictionary>(std::shared_ptr<const Dictionary>(), &dict);
}

// Restores the mapper and the totals from the checkpoint when the job resumes one; returns
// whether it did.
bool resume(const MapCheckpointing& c, Mapper& mapper, MapRunTotals& totals, std::size_t scans) {
  std::error_code ec;
  if (!c.resume || c.path.empty() || !std::filesystem::exists(c.path, ec)) return false;
  nlohmann::json saved;
  decode_checkpoint(Mapper::state_extra(c.path), c.path, saved, totals);
  check_same_run(c.path, saved, nlohmann::json::parse(c.run));
  mapper.load_state(c.path);
  if (mapper.scans() != totals.scans || mapper.scans() > scans)
    throw InputError(c.path + ": the checkpoint holds " + std::to_string(mapper.scans()) +
                     " mapped scans and totals of " + std::to_string(totals.scans) + ", of " +
                     std::to_string(scans));
  return true;
}

// Resumes from the checkpoint where there is one; says what it did, and what a stopped run's
// checkpoint will come to.
void start_or_resume(const MapJob& job, Mapper& mapper, MapRunTotals& t, std::size_t scans,
                     MapJobResult& r) {
  const MapCheckpointing& ck = job.checkpoint;
  auto note = [&job](const std::string& line) {
    if (job.note) job.note(line);
  };
  if (!ck.path.empty()) remove_stale_temporaries(ck.path);
  if (resume(ck, mapper, t, scans)) {
    r.resumed_at = mapper.scans();
    note(format("resumed from %s at scan %zu/%zu (%zu scans mapped before)", ck.path.c_str(),
                r.resumed_at + 1, scans, r.resumed_at));
  } else if (ck.resume) {
    note("no checkpoint at " + ck.path + "; starting from scan 1");
  } else if (std::error_code ec; !ck.path.empty() && std::filesystem::exists(ck.path, ec)) {
    note(ck.path + " exists (a stopped run?) and will be replaced; --resume would continue it");
  }
}

}  // namespace

void summarise(MapJobResult& r, const MapRunTotals& t, Context* ctx) {
  const MapRunSummary s = summarise_run(ctx, r.overall_map(), t);
  r.scans = s.scans;
  r.mean_timing = s.mean_timing;
  r.mean_wall_ms = s.mean_wall_ms;
  r.max_wall_ms = s.max_wall_ms;
  r.kernels_per_scan = s.kernels_per_scan;
  r.instantaneous = s.instantaneous;
  r.overall_scores = s.overall;
  if (!t.ahead_prob.empty()) {
    LookAhead ahead;
    ahead.prob = t.ahead_prob;
    ahead.label = t.ahead_label;
    ahead.beyond = t.ahead_beyond;
    lookahead_scores(ahead, r.lookahead, r.lookahead_beyond);
  }
}

const KernelMap& MapJobResult::overall_map() const {
  return merged ? merged->map : mapper->overall_map();
}

std::size_t MapJobResult::overall_kernels() const {
  return merged ? merged->kernels() : mapper->overall_kernels();
}

std::size_t MapJobResult::overall_memory_bytes() const {
  return merged ? merged->memory_bytes() : mapper->overall_memory_bytes();
}

void MapJobResult::write_overall_map(const std::string& path) const {
  if (!merged)
    write_mapper_map(*mapper, path);
  else if (merged->joint)
    write_joint_bhm_map(*merged->joint, path, &merged->map);
  else
    write_averaged_map(*merged->averaged, path);
}

std::string MapJobResult::to_json() const {
  nlohmann::json j = {{"scans", scans},
                      {"overall_kernels", overall_kernels()},
                      {"overall_memory_bytes", overall_memory_bytes()},
                      {"overall_kind", persistent()                        ? "persistent joint BHM"
                                       : mapper->options().average_overall ? "averaged maps"
                                                                           : "merged kernels"},
                      {"kernels_per_scan", kernels_per_scan},
                      {"instantaneous", scores_json(instantaneous)},
                      {"overall", scores_json(overall_scores)},
                      {"ms_per_scan",
                       {{"prepare", mean_timing.prepare_ms},
                        {"ranking", mean_timing.ranking_ms},
                        {"transport", mean_timing.transport_ms},
                        {"placement", mean_timing.placement_ms},
                        {"refine", mean_timing.refine_ms},
                        {"solve_wall", mean_wall_ms},
                        {"solve_wall_max", max_wall_ms}}},
                      {"total_seconds", total_seconds}};
  if (merged) j["ranks"] = merged->record;
  if (lookahead.n) {
    auto json = [](const Scores& s) {
      return nlohmann::json{{"auc", s.auc}, {"nll", s.nll}, {"n", s.n}};
    };
    j["lookahead"] = {{"all", json(lookahead)}, {"beyond_reach", json(lookahead_beyond)}};
    j["lookahead_ms_per_scan"] = totals.ahead_ms / double(std::max<std::size_t>(scans, 1));
  }
  return j.dump();
}

MapJobResult run_map_job(Context* ctx, const Dictionary& dict, const std::vector<Scan>& scans,
                         const MapJob& job) {
  MapJobResult r;
  r.mapper = std::make_unique<Mapper>(ctx, borrowed(dict), job.mapper, job.overall);
  Mapper& mapper = *r.mapper;
  const MapCheckpointing& ck = job.checkpoint;
  MapRunTotals t;
  t.test.dim = dict.dim;
  if (job.start_at > 0) mapper.start_at(job.start_at);
  start_or_resume(job, mapper, t, scans.size(), r);
  const auto t0 = std::chrono::steady_clock::now();
  auto last_checkpoint = t0;
  if (!job.instantaneous_dir.empty()) std::filesystem::create_directories(job.instantaneous_dir);
  // After each scan's merge (on map_scored's worker, beside the next scan's transfer): its
  // instantaneous map, its report and the checkpoint.
  auto after_scan = [&](const MappedScan& done) {
    const ScanTransfer& tr = done.transfer;
    if (!job.instantaneous_dir.empty()) {
      char name[64];
      std::snprintf(name, sizeof name, "scan_%06zu.potmap", done.index);
      write_map(tr.map, (std::filesystem::path(job.instantaneous_dir) / name).string());
    }
    if (job.after_scan)
      job.after_scan(done.index, done.index + 1 - job.start_at, scans.size() - job.start_at,
                     format("scan %zu/%zu: %zu sectors, %zu kernels, %.1f ms (ranking %.1f, "
                            "transport %.1f, placement %.1f, refine %.1f); overall %zu kernels",
                            done.index + 1, scans.size(), tr.sectors.size(), tr.map.size(),
                            done.wall_ms, tr.timing.ranking_ms, tr.timing.transport_ms,
                            tr.timing.placement_ms, tr.timing.refine_ms, mapper.overall_kernels()));
    // A checkpoint after the last scan would only be removed again.
    if (ck.path.empty() || t.scans == scans.size()) return;
    const auto now = std::chrono::steady_clock::now();
    const bool by_count = ck.every > 0 && t.scans % ck.every == 0;
    const bool by_time =
        ck.every_seconds > 0 &&
        std::chrono::duration<double>(now - last_checkpoint).count() >= ck.every_seconds;
    if (!by_count && !by_time) return;
    const double seconds = t.seconds + std::chrono::duration<double>(now - t0).count();
    mapper.save_state(ck.path, encode_checkpoint(nlohmann::json::parse(ck.run), t, seconds));
    last_checkpoint = std::chrono::steady_clock::now();
    ++r.checkpoints;
    r.checkpoint_seconds += std::chrono::duration<double>(last_checkpoint - now).count();
  };
  map_scored(ctx, mapper, scans, t, after_scan, job.lookahead);
  summarise(r, t, ctx);
  r.total_seconds = t.seconds + seconds_since(t0);
  r.totals = std::move(t);
  return r;
}

}  // namespace potmap::job
