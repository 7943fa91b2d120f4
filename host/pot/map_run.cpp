#include "potmap/pot/map_run.hpp"

#include <algorithm>
#include <future>

#include "potmap/map/evaluate.hpp"

namespace potmap {

namespace {

// The instantaneous map on its own scan's held-out samples (exact sum: a few thousand points),
// kept for the run's scores, and those samples kept to score the overall map at the end.
void add_held_out(const MappedScan& m, MapRunTotals& t) {
  if (m.test.empty()) return;
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

}  // namespace

void map_scored(Context* ctx, Mapper& mapper, const std::vector<Scan>& scans, MapRunTotals& totals,
                const std::function<void(const MappedScan&)>& after_scan) {
  auto merge_scan = [&](MappedScan&& m) {
    add_held_out(m, totals);
    mapper.add_mapped(std::move(m));
    const MappedScan& done = mapper.last();
    add_to_totals(totals, done);
    if (after_scan) after_scan(done);
  };
  const auto launch = mapper.options().pipeline ? std::launch::async : std::launch::deferred;
  std::future<void> merging;
  // The mapper's options carry the ranking's preselector or index, built once.
  map_scans(
      ctx, mapper.dictionary(), scans, mapper.options(),
      [&](MappedScan&& m) {
        if (merging.valid()) merging.get();
        merging = std::async(
            launch, [&merge_scan, m = std::move(m)]() mutable { merge_scan(std::move(m)); });
      },
      mapper.continuation());
  if (merging.valid()) merging.get();
}

MapRunSummary summarise_run(Context* ctx, const Mapper& mapper, const MapRunTotals& t) {
  MapRunSummary r;
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
    const KernelMap& overall = mapper.overall_map();
    if (ctx && !overall.empty()) {
      MapEvaluator ev(*ctx, overall);
      ev.evaluate(test.position.data(), test.size(), nullptr, nullptr, prob.data());
    } else {
      const MapValuesExact v = evaluate_exact(overall, test.position.data(), test.size());
      for (std::size_t j = 0; j < test.size(); ++j) prob[j] = static_cast<float>(v.prob[j]);
    }
    r.overall = score(prob, test.label);
  }
  return r;
}

}  // namespace potmap
