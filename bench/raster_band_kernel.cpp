// The height-band kernel alone on a raster window: MapEvaluator::evaluate_band_max over the same
// cells and heights as `potmap raster --band`, warm (program built, buffers allocated), timed
// `repeat` times. Prints JSON (device, cells, levels, seconds) for bench/raster_band.py.
//
// Usage: raster_band_kernel MAP XMIN,XMAX,YMIN,YMAX|auto RES ZLO,ZHI [STEP (0: the map's)]
//        [REPEAT]
#include <sys/resource.h>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "potmap/io/map_io.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/raster.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;

namespace {

std::vector<double> numbers(const char* text) {
  std::vector<double> v;
  std::string s(text);
  std::size_t at = 0;
  while (at <= s.size()) {
    const std::size_t comma = std::min(s.find(',', at), s.size());
    v.push_back(std::stod(s.substr(at, comma - at)));
    at = comma + 1;
  }
  return v;
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc < 5) {
    std::fprintf(stderr, "usage: %s MAP XMIN,XMAX,YMIN,YMAX RES ZLO,ZHI [STEP] [REPEAT]\n",
                 argv[0]);
    return 2;
  }
  const KernelMap map = read_map(argv[1]);
  // "auto": the kernels' extent.
  std::vector<double> b;
  if (std::string(argv[2]) == "auto") {
    double lo[3], hi[3];
    map.bounds(lo, hi);
    b = {lo[0], hi[0], lo[1], hi[1]};
  } else {
    b = numbers(argv[2]);
  }
  const std::vector<double> band = numbers(argv[4]);
  RasterSpec spec;
  spec.xmin = b.at(0);
  spec.xmax = b.at(1);
  spec.ymin = b.at(2);
  spec.ymax = b.at(3);
  spec.resolution = std::atof(argv[3]);
  spec.band_lo = band.at(0);
  spec.band_hi = band.at(1);
  spec.band_step = argc > 5 ? std::atof(argv[5]) : 0.0;
  const int repeat = argc > 6 ? std::atoi(argv[6]) : 3;
  const std::vector<double> levels = raster_levels(spec, map);
  GridSpec g;
  g.dim = 3;
  g.resolution = spec.resolution;
  g.origin[0] = spec.xmin;
  g.origin[1] = spec.ymin;
  g.count[0] = spec.width();
  g.count[1] = spec.height();
  Context ctx;
  MapEvaluator ev(ctx, map);
  const std::size_t n = g.count[0] * g.count[1];
  std::vector<float> var(n), prob(n);
  ev.evaluate_band_max(g, levels, nullptr, var.data(), prob.data());  // warm
  // Wall time, and the process's CPU time (all threads, the device's included on a CPU device):
  // on a machine that other work loads, CPU time still measures this work alone.
  auto cpu_seconds = [] {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
           1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
  };
  std::string times, cpu;
  for (int r = 0; r < repeat; ++r) {
    const double c0 = cpu_seconds();
    const auto t0 = std::chrono::steady_clock::now();
    ev.evaluate_band_max(g, levels, nullptr, var.data(), prob.data());
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    times += (r ? ", " : "") + std::to_string(s);
    cpu += (r ? ", " : "") + std::to_string(cpu_seconds() - c0);
  }
  std::printf(
      "{\"device\": \"%s\", \"kernels\": %zu, \"bounds\": \"%.17g,%.17g,%.17g,%.17g\", "
      "\"cells\": %zu, \"levels\": %zu, \"level_spacing\": %.6g, \"pairs\": %zu, "
      "\"seconds\": [%s], \"cpu_seconds\": [%s]}\n",
      ctx.info().name.c_str(), map.size(), b[0], b[1], b[2], b[3], n, levels.size(),
      levels.size() > 1 ? levels[1] - levels[0] : 0.0, ev.last_pairs(), times.c_str(), cpu.c_str());
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "raster_band_kernel: %s\n", e.what());
  return 1;
}
