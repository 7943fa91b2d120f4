#include "map_pipeline.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <future>

#include "map_checkpoint.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/map/evaluate.hpp"
#include "progress.hpp"

namespace potmap::cli {

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
  check_same_run(c.path, saved, c.run);
  mapper.load_state(c.path);
  if (mapper.scans() != totals.scans || mapper.scans() > scans)
    throw InputError(c.path + ": the checkpoint holds " + std::to_string(mapper.scans()) +
                     " mapped scans and totals of " + std::to_string(totals.scans) + ", of " +
                     std::to_string(scans));
  return true;
}

// Resumes from the checkpoint where there is one; says what it did, and what a stopped run's
// checkpoint will come to, on stderr.
void start_or_resume(const MapCheckpointing& ck, Mapper& mapper, MapRunTotals& t, std::size_t scans,
                     MapJobResult& r) {
  if (!ck.path.empty()) remove_stale_temporaries(ck.path);
  if (resume(ck, mapper, t, scans)) {
    r.resumed_at = mapper.scans();
    std::fprintf(stderr, "potmap map: resumed from %s at scan %zu/%zu (%zu scans mapped before)\n",
                 ck.path.c_str(), r.resumed_at + 1, scans, r.resumed_at);
  } else if (ck.resume) {
    std::fprintf(stderr, "potmap map: no checkpoint at %s; starting from scan 1\n",
                 ck.path.c_str());
  } else if (std::error_code ec; !ck.path.empty() && std::filesystem::exists(ck.path, ec)) {
    std::fprintf(stderr,
                 "potmap map: %s exists (a stopped run?) and will be replaced; --resume would "
                 "continue it\n",
                 ck.path.c_str());
  }
}

// The instantaneous map on its own scan's held-out samples (exact sum: a few thousand points),
// kept for the run's scores, and those samples kept to score the overall map at the end.
void add_held_out(const MappedScan& m, MapRunTotals& t) {
  if (!m.test.empty()) {
    const MapValuesExact v = evaluate_exact(m.transfer.map, m.test.position.data(), m.test.size());
    for (std::size_t j = 0; j < m.test.size(); ++j) {
      t.inst_prob.push_back(static_cast<float>(v.prob[j]));
      t.labels.push_back(m.test.label[j]);
    }
    LabelledPoints& test = t.test;
    test.position.insert(test.position.end(), m.test.position.begin(), m.test.position.end());
    test.label.insert(test.label.end(), m.test.label.begin(), m.test.label.end());
    test.scan.insert(test.scan.end(), m.test.scan.begin(), m.test.scan.end());
  }
}

void add_to_totals(MapRunTotals& t, const MappedScan& done) {
  const ScanTransfer& tr = done.transfer;
  t.timing.prepare_ms += tr.timing.prepare_ms;
  t.timing.ranking_ms += tr.timing.ranking_ms;
  t.timing.transport_ms += tr.timing.transport_ms;
  t.timing.placement_ms += tr.timing.placement_ms;
  t.timing.refine_ms += tr.timing.refine_ms;
  t.wall_ms += done.wall_ms;
  t.max_wall_ms = std::max(t.max_wall_ms, done.wall_ms);
  t.kernels += tr.map.size();
  ++t.scans;
}

// The per-scan means, and the overall map scored on every scan's held-out samples.
void summarise(MapJobResult& r, const MapRunTotals& t, Context* ctx) {
  r.scans = t.scans;
  if (r.scans > 0) {
    const double n = double(r.scans);
    r.mean_timing.prepare_ms = t.timing.prepare_ms / n;
    r.mean_timing.ranking_ms = t.timing.ranking_ms / n;
    r.mean_timing.transport_ms = t.timing.transport_ms / n;
    r.mean_timing.placement_ms = t.timing.placement_ms / n;
    r.mean_timing.refine_ms = t.timing.refine_ms / n;
    r.mean_wall_ms = t.wall_ms / n;
    r.max_wall_ms = t.max_wall_ms;
    r.kernels_per_scan = t.kernels / r.scans;
  }
  r.instantaneous = score(t.inst_prob, t.labels);
  const LabelledPoints& test = t.test;
  if (!test.empty()) {
    std::vector<float> prob(test.size());
    const KernelMap& overall = r.overall_map();
    if (ctx && !overall.empty()) {
      MapEvaluator ev(*ctx, overall);
      ev.evaluate(test.position.data(), test.size(), nullptr, nullptr, prob.data());
    } else {
      const MapValuesExact v = evaluate_exact(overall, test.position.data(), test.size());
      for (std::size_t j = 0; j < test.size(); ++j) prob[j] = static_cast<float>(v.prob[j]);
    }
    r.overall_scores = score(prob, test.label);
  }
}

}  // namespace

nlohmann::json MapJobResult::to_json() const {
  return {{"scans", scans},
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
}

MapJobResult run_map_job(Context* ctx, const Dictionary& dict, const std::vector<Scan>& scans,
                         const MapJob& job) {
  MapJobResult r;
  r.mapper = std::make_unique<Mapper>(ctx, borrowed(dict), job.mapper, job.overall);
  Mapper& mapper = *r.mapper;
  const MapCheckpointing& ck = job.checkpoint;
  MapRunTotals t;
  t.test.dim = dict.dim;
  start_or_resume(ck, mapper, t, scans.size(), r);
  const auto t0 = std::chrono::steady_clock::now();
  auto last_checkpoint = t0;
  if (!job.instantaneous_dir.empty()) std::filesystem::create_directories(job.instantaneous_dir);
  auto progress = job.verbose ? std::function<void(double)>() : terminal_progress("map");
  // Everything after a scan's transfer (its scores, the overall map's merge or RePOT's update,
  // the checkpoint) runs on a worker beside the next scan's transfer, which reads none of it;
  // the scans still reach the mapper one at a time and in order, so the maps are a serial
  // run's.
  auto merge_scan = [&](MappedScan&& m) {
    add_held_out(m, t);
    mapper.add_mapped(std::move(m));
    const MappedScan& done = mapper.last();
    const ScanTransfer& tr = done.transfer;
    if (!job.instantaneous_dir.empty()) {
      char name[64];
      std::snprintf(name, sizeof name, "scan_%06zu.potmap", done.index);
      write_map(tr.map, (std::filesystem::path(job.instantaneous_dir) / name).string());
    }
    add_to_totals(t, done);
    if (job.verbose) {
      std::fprintf(stderr,
                   "potmap map: scan %zu/%zu: %zu sectors, %zu kernels, %.1f ms (ranking "
                   "%.1f, transport %.1f, placement %.1f, refine %.1f); overall %zu "
                   "kernels\n",
                   done.index + 1, scans.size(), tr.sectors.size(), tr.map.size(), done.wall_ms,
                   tr.timing.ranking_ms, tr.timing.transport_ms, tr.timing.placement_ms,
                   tr.timing.refine_ms, mapper.overall_kernels());
    } else if (progress) {
      progress(double(done.index + 1) / double(scans.size()));
    }
    // A checkpoint after the last scan would only be removed again.
    if (ck.path.empty() || t.scans == scans.size()) return;
    const auto now = std::chrono::steady_clock::now();
    const bool by_count = ck.every > 0 && t.scans % ck.every == 0;
    const bool by_time =
        ck.every_seconds > 0 &&
        std::chrono::duration<double>(now - last_checkpoint).count() >= ck.every_seconds;
    if (!by_count && !by_time) return;
    const double seconds = t.seconds + std::chrono::duration<double>(now - t0).count();
    mapper.save_state(ck.path, encode_checkpoint(ck.run, t, seconds));
    last_checkpoint = std::chrono::steady_clock::now();
    ++r.checkpoints;
    r.checkpoint_seconds += std::chrono::duration<double>(last_checkpoint - now).count();
  };
  const auto launch = mapper.options().pipeline ? std::launch::async : std::launch::deferred;
  std::future<void> merging;
  // The mapper's options carry the ranking's preselector or index, built once.
  map_scans(
      ctx, dict, scans, mapper.options(),
      [&](MappedScan&& m) {
        if (merging.valid()) merging.get();
        merging = std::async(
            launch, [&merge_scan, m = std::move(m)]() mutable { merge_scan(std::move(m)); });
      },
      mapper.continuation());
  if (merging.valid()) merging.get();
  summarise(r, t, ctx);
  r.total_seconds = t.seconds + seconds_since(t0);
  return r;
}

}  // namespace potmap::cli
