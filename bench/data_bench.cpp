// Ingestion speed: scans per second per reader on the real data, labelled samples per second,
// and one KITTI 64-beam frame read + labelled (the issue asks well under 10 ms).
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>

#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/data/simulator.hpp"

namespace {

std::string data(const std::string& rel) {
  return (std::filesystem::path(POTMAP_SOURCE_DIR) / ".." / "shared" / "data" / rel).string();
}

void carmen(benchmark::State& st, const char* rel) {
  const std::string p = data(rel);
  if (!std::filesystem::exists(p)) return st.SkipWithError("no ../shared/data");
  std::size_t scans = 0;
  for (auto _ : st) scans += potmap::read_carmen(p).scans.size();
  st.counters["scans/s"] =
      benchmark::Counter(static_cast<double>(scans), benchmark::Counter::kIsRate);
}
BENCHMARK_CAPTURE(carmen, intel, "radish/intel-corrected.log.gz")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(carmen, csail, "radish/csail-corrected.log.gz")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(carmen, freiburg, "radish/freiburg-079-corrected.log.gz")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2);

void velodyne(benchmark::State& st, const char* rel, bool nuscenes) {
  const std::string p = data(rel);
  if (!std::filesystem::exists(p)) return st.SkipWithError("no ../shared/data");
  for (auto _ : st)
    benchmark::DoNotOptimize(nuscenes ? potmap::read_nuscenes_bin(p) : potmap::read_kitti_bin(p));
  st.counters["scans/s"] =
      benchmark::Counter(static_cast<double>(st.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK_CAPTURE(velodyne, kitti, "lidar3d/kitti_000008.bin", false)
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(velodyne, nuscenes, "lidar3d/nuscenes_lidar_top_1532402927647951.bin", true)
    ->Unit(benchmark::kMillisecond);

// The real-time budget: read one 64-beam frame and label it (default one free sample per metre).
void kitti_read_and_label(benchmark::State& st) {
  const std::string p = data("lidar3d/kitti_000008.bin");
  if (!std::filesystem::exists(p)) return st.SkipWithError("no ../shared/data");
  std::size_t samples = 0;
  for (auto _ : st) {
    potmap::LabelledSplit out;
    potmap::label_scan(potmap::read_kitti_bin(p), 0, potmap::LabelOptions{}, out);
    samples += out.train.size() + out.test.size();
  }
  st.counters["samples/s"] =
      benchmark::Counter(static_cast<double>(samples), benchmark::Counter::kIsRate);
}
BENCHMARK(kitti_read_and_label)->Unit(benchmark::kMillisecond);

void label_intel(benchmark::State& st) {
  const std::string p = data("radish/intel-corrected.log.gz");
  if (!std::filesystem::exists(p)) return st.SkipWithError("no ../shared/data");
  std::vector<potmap::Scan> scans = potmap::read_carmen(p).scans;
  scans.resize(100);
  for (auto& s : scans) s.max_range = 20;  // an indoor r_max, as a mapper would use
  std::size_t samples = 0;
  for (auto _ : st) {
    const potmap::LabelledSplit out = potmap::label_scans(scans);
    samples += out.train.size() + out.test.size();
  }
  st.counters["samples/s"] =
      benchmark::Counter(static_cast<double>(samples), benchmark::Counter::kIsRate);
}
BENCHMARK(label_intel)->Unit(benchmark::kMillisecond);

void simulate_2d(benchmark::State& st) {
  const potmap::Town t = potmap::Town::builtin("town1");
  potmap::SimOptions o;
  o.scans = 200;
  for (auto _ : st) benchmark::DoNotOptimize(potmap::simulate(t, o));
  st.counters["scans/s"] = benchmark::Counter(200.0 * st.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(simulate_2d)->Unit(benchmark::kMillisecond);

void simulate_3d(benchmark::State& st) {
  const potmap::Town t = potmap::Town::builtin("town1");
  potmap::SimOptions o;
  o.scans = 5;
  o.three_d = true;
  for (auto _ : st) benchmark::DoNotOptimize(potmap::simulate(t, o));
  st.counters["scans/s"] = benchmark::Counter(5.0 * st.iterations(), benchmark::Counter::kIsRate);
}
BENCHMARK(simulate_3d)->Unit(benchmark::kMillisecond);

}  // namespace
