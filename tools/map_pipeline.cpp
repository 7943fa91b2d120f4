#include "map_pipeline.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>

#include "potmap/io/map_io.hpp"
#include "potmap/map/evaluate.hpp"
#include "progress.hpp"

namespace potmap::cli {

namespace {

nlohmann::json scores_json(const Scores& s) {
  return {{"acc", s.acc}, {"auc", s.auc}, {"nll", s.nll}, {"points", s.n}};
}

}  // namespace

nlohmann::json MapJobResult::to_json() const {
  return {{"scans", scans},
          {"overall_kernels", overall_kernels()},
          {"overall_memory_bytes", overall_memory_bytes()},
          {"overall_kind", repot ? "persistent joint BHM" : "merged kernels"},
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
  MapJobResult r{OverallMap(dict.dim, job.overall)};
  if (persistent_refine(job.mapper)) r.repot.emplace(dict.dim, job.mapper);
  const auto t0 = std::chrono::steady_clock::now();
  if (!job.instantaneous_dir.empty()) std::filesystem::create_directories(job.instantaneous_dir);
  std::vector<float> inst_prob;
  std::vector<std::uint8_t> labels;
  LabelledPoints test;
  test.dim = dict.dim;
  auto progress = job.verbose ? std::function<void(double)>() : terminal_progress("map");
  std::size_t kernels = 0;
  map_scans(ctx, dict, scans, job.mapper, [&](MappedScan&& m) {
    const ScanTransfer& t = m.transfer;
    // The instantaneous map on its own scan's held-out samples (exact sum: a few thousand points).
    if (!m.test.empty()) {
      const MapValuesExact v = evaluate_exact(t.map, m.test.position.data(), m.test.size());
      for (std::size_t j = 0; j < m.test.size(); ++j) {
        inst_prob.push_back(static_cast<float>(v.prob[j]));
        labels.push_back(m.test.label[j]);
      }
      test.position.insert(test.position.end(), m.test.position.begin(), m.test.position.end());
      test.label.insert(test.label.end(), m.test.label.begin(), m.test.label.end());
      test.scan.insert(test.scan.end(), m.test.scan.begin(), m.test.scan.end());
    }
    double refine_ms = t.timing.refine_ms;
    if (r.repot) {
      const auto r0 = std::chrono::steady_clock::now();
      r.repot->add(t.map, m.train);
      refine_ms +=
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - r0).count();
    } else if (!t.map.empty()) {
      r.overall.add(t.map);
    }
    if (!job.instantaneous_dir.empty()) {
      char name[64];
      std::snprintf(name, sizeof name, "scan_%06zu.potmap", m.index);
      write_map(t.map, (std::filesystem::path(job.instantaneous_dir) / name).string());
    }
    r.mean_timing.prepare_ms += t.timing.prepare_ms;
    r.mean_timing.ranking_ms += t.timing.ranking_ms;
    r.mean_timing.transport_ms += t.timing.transport_ms;
    r.mean_timing.placement_ms += t.timing.placement_ms;
    r.mean_timing.refine_ms += refine_ms;
    r.mean_wall_ms += m.wall_ms;
    r.max_wall_ms = std::max(r.max_wall_ms, m.wall_ms);
    kernels += t.map.size();
    ++r.scans;
    if (job.verbose) {
      std::fprintf(stderr,
                   "potmap map: scan %zu/%zu: %zu sectors, %zu kernels, %.1f ms (ranking %.1f, "
                   "transport %.1f, placement %.1f, refine %.1f); overall %zu kernels\n",
                   m.index + 1, scans.size(), t.sectors.size(), t.map.size(), m.wall_ms,
                   t.timing.ranking_ms, t.timing.transport_ms, t.timing.placement_ms, refine_ms,
                   r.overall_kernels());
    } else if (progress) {
      progress(double(m.index + 1) / double(scans.size()));
    }
  });
  if (r.scans > 0) {
    const double n = double(r.scans);
    r.mean_timing.prepare_ms /= n;
    r.mean_timing.ranking_ms /= n;
    r.mean_timing.transport_ms /= n;
    r.mean_timing.placement_ms /= n;
    r.mean_timing.refine_ms /= n;
    r.mean_wall_ms /= n;
    r.kernels_per_scan = kernels / r.scans;
  }
  r.instantaneous = score(inst_prob, labels);
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
  r.total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace potmap::cli
