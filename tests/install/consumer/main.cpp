// Evaluates a one-kernel map through an installed potmap and checks the probability against
// the model's formula, then reaches the mapping job through its installed header (a job with no
// output folder is refused). Exit status 0 only if both hold.
#include <cmath>
#include <cstdio>

#include "potmap/error.hpp"
#include "potmap/job/mapping_job.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/kernel_map.hpp"
#include "potmap/runtime/context.hpp"
#include "potmap/version.hpp"

int main() {
  try {
    potmap::Context ctx;
    potmap::KernelMap map;
    const double h[2] = {1.0, 2.0};
    map.push_back(h, 0.5, 2.0, 0.3);
    potmap::MapEvaluator ev(ctx, map);
    const double q[2] = {1.5, 2.0};
    float prob = -1;
    ev.evaluate(q, 1, nullptr, nullptr, &prob);

    const double phi = std::exp(-0.5 * 0.25);
    const double mu = 2.0 * phi, s2 = 0.3 * phi * phi;
    const double want = 1.0 / (1.0 + std::exp(-mu / std::sqrt(1.0 + M_PI * s2 / 8.0)));
    std::printf("potmap %s on %s: p = %.7f (expected %.7f)\n", POTMAP_VERSION_STRING,
                ctx.info().summary().c_str(), prob, want);
    if (!(std::fabs(prob - want) < 1e-5)) {
      std::fprintf(stderr, "wrong probability\n");
      return 1;
    }
    try {
      potmap::run_mapping_job(ctx, "any", potmap::MappingJobOptions{});
      std::fprintf(stderr, "the mapping job ran without an output folder\n");
      return 1;
    } catch (const potmap::ArgumentError& e) {
      std::printf("mapping job: %s\n", e.what());
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}
