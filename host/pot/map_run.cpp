#include "potmap/pot/map_run.hpp"

#include <algorithm>
#include <chrono>
#include <future>

#include "potmap/error.hpp"
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

// The persistent map as it stands on the scan's held-out samples, before the scan joins it.
void look_ahead(const Mapper& mapper, const MappedScan& m, MapRunTotals& t, Context* ctx) {
  if (mapper.scans() == 0 || m.test.empty()) return;
  const auto t0 = std::chrono::steady_clock::now();
  const JointBhm& learner = mapper.repot()->learner();
  const std::size_t n = m.test.size();
  std::vector<double> mean(n), var(n);
  learner.predict(m.test.position.data(), n, mean.data(), var.data(), ctx);
  std::vector<std::uint8_t> reached(n);
  learner.reached(m.test.position.data(), n, reached.data());
  for (std::size_t i = 0; i < n; ++i) {
    t.ahead_prob.push_back(static_cast<float>(probit_probability(mean[i], var[i])));
    t.ahead_label.push_back(m.test.label[i]);
    t.ahead_beyond.push_back(reached[i] ? 0 : 1);
  }
  t.ahead_ms +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
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
                const std::function<void(const MappedScan&)>& after_scan, bool lookahead) {
  if (lookahead && !persistent_refine(mapper.options()))
    throw ArgumentError(
        "look-ahead: scored on RePOT's persistent map (POT's averaged map: potmap experiment "
        "--lookahead)");
  auto merge_scan = [&](MappedScan&& m) {
    add_held_out(m, totals);
    if (lookahead) look_ahead(mapper, m, totals, ctx);
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
  return summarise_run(ctx, mapper.overall_map(), t);
}

void add_totals(MapRunTotals& into, const MapRunTotals& part) {
  if (!part.test.empty() && !into.test.empty() && part.test.dim != into.test.dim)
    throw ArgumentError("add_totals: held-out samples of " + std::to_string(part.test.dim) +
                        "D added to " + std::to_string(into.test.dim) + "D ones");
  auto append = [](auto& a, const auto& b) { a.insert(a.end(), b.begin(), b.end()); };
  append(into.inst_prob, part.inst_prob);
  append(into.labels, part.labels);
  if (into.test.empty()) into.test.dim = part.test.dim;
  append(into.test.position, part.test.position);
  append(into.test.label, part.test.label);
  append(into.test.scan, part.test.scan);
  append(into.ahead_prob, part.ahead_prob);
  append(into.ahead_label, part.ahead_label);
  append(into.ahead_beyond, part.ahead_beyond);
  into.ahead_ms += part.ahead_ms;
  into.timing.prepare_ms += part.timing.prepare_ms;
  into.timing.ranking_ms += part.timing.ranking_ms;
  into.timing.transport_ms += part.timing.transport_ms;
  into.timing.placement_ms += part.timing.placement_ms;
  into.timing.refine_ms += part.timing.refine_ms;
  into.wall_ms += part.wall_ms;
  into.max_wall_ms = std::max(into.max_wall_ms, part.max_wall_ms);
  into.kernels += part.kernels;
  into.scans += part.scans;
}

MapRunSummary summarise_run(Context* ctx, const KernelMap& overall, const MapRunTotals& t) {
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
