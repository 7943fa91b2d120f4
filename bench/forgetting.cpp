// Forgetting (JointBhmOptions::half_life) on a 2D log or a 3D drive, for several half-lives in
// one run: what a map that forgets does where the world changed and what it costs elsewhere.
//
// For each half-life (0: never forget) the scans are learned in order, each at its timestamp:
//  - 2D logs: the persistent joint BHM of RePOT at its defaults (0.5 m kernels; no seeds), each
//    scan cut at --range-cut and labelled as `potmap mapping` labels it;
//  - 3D drives: DriveMapper at the drive defaults (`potmap mapping DRIVE`).
// and reports
//  - overall: the final map on every scan's held-out samples (as `potmap mapping` scores);
//  - now: every --now-every-th scan, the map right after it on that scan's own held-out
//    samples: what the map says about the world as the sensor sees it at that moment;
//  - left: the map's probability at the places the data say something left, read at every
//    --now-every-th scan: a cell (--cell metres) hit in --stood scans (default 3: something
//    stood there), then passed free by at least two later scans (one of them since the last
//    reading) and not hit again (a car that drove off, a door opened, a person gone); the mean
//    probability there and the fraction still read occupied (p > 0.65, what a ROS map calls
//    occupied). "left at end" reads the final map at every such cell;
//  - ms per scan, and the learner's memory at the end.
// Prints a table, writes JSON.
//
// Usage: forgetting INPUT [--half-life 0,5,20] [--first 0] [--max-scans 0] [--range-cut R]
//                         [--now-every 10] [--stood 3] [--cell C] [--json forgetting.json]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

#include <nlohmann/json.hpp>

#include "potmap/data/drive.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/mapping/drive_mapper.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;

namespace {

struct Args {
  std::string input, json = "forgetting.json";
  std::vector<double> half_lives = {0, 5, 20};
  std::size_t first = 0, max_scans = 0, now_every = 10;
  int stood = 3;                     // scans a place must be hit in before it was left
  double range_cut = -1, cell = -1;  // -1: 20 m and 0.25 m in 2D, 40 m and 0.5 m in 3D
};

bool parse(int argc, char** argv, Args& a) {
  if (argc < 2) return false;
  a.input = argv[1];
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--half-life") {
      a.half_lives.clear();
      std::stringstream ss(v);
      for (std::string x; std::getline(ss, x, ',');) a.half_lives.push_back(std::stod(x));
    } else if (k == "--first") {
      a.first = std::stoul(v);
    } else if (k == "--max-scans") {
      a.max_scans = std::stoul(v);
    } else if (k == "--range-cut") {
      a.range_cut = std::stod(v);
    } else if (k == "--now-every") {
      a.now_every = std::max<std::size_t>(1, std::stoul(v));
    } else if (k == "--stood") {
      a.stood = std::max(1, std::stoi(v));
    } else if (k == "--cell") {
      a.cell = std::stod(v);
    } else if (k == "--json") {
      a.json = v;
    } else {
      std::fprintf(stderr, "forgetting: unknown option %s\n", k.c_str());
      return false;
    }
  }
  return (argc % 2) == 0;
}

// The scans of a log or the keyframes of a drive, one at a time.
struct Source {
  int dim = 2;
  std::vector<Scan> scans;  // 2D
  std::unique_ptr<Drive> drive;
  std::size_t first = 0, count = 0;
  Scan at(std::size_t i) const {
    return drive ? read_keyframe(*drive, first + i) : scans[first + i];
  }
};

Source open_source(const Args& a) {
  Source s;
  if (is_drive(a.input)) {
    s.dim = 3;
    s.drive = std::make_unique<Drive>(open_drive(a.input));
    s.count = s.drive->size();
  } else {
    s.scans = read_dataset(a.input).scans;
    s.count = s.scans.size();
    if (!s.scans.empty()) s.dim = s.scans.front().dim;
  }
  s.first = std::min(a.first, s.count);
  s.count -= s.first;
  if (a.max_scans > 0) s.count = std::min(s.count, a.max_scans);
  return s;
}

// Cells hit and later seen free (the "left" places above).
class LeftPlaces {
 public:
  LeftPlaces(int dim, double cell, int stood) : dim_(dim), stood_(stood), cell_(cell) {}
  void add(const LabelledPoints& p, int scan) {
    for (std::size_t i = 0; i < p.size(); ++i) {
      Cell& c = cells_[key(&p.position[i * std::size_t(dim_)])];
      if (p.label[i]) {
        // Scans that hit it since it was last seen free: how long something stood there.
        if (c.free_after > 0) c.hit_scans = 0;
        if (c.last_hit != scan) ++c.hit_scans;
        c.last_hit = scan;
        c.free_after = 0;
      } else if (c.last_hit >= 0 && scan > c.last_hit && c.last_free != scan) {
        ++c.free_after;
        c.last_free = scan;
      }
    }
  }
  // The centres of the cells left, those last seen free at scan `since` or later.
  std::vector<double> centres(int since = -1) const {
    std::vector<double> out;
    for (const auto& [k, c] : cells_) {
      if (c.hit_scans < stood_ || c.free_after < 2 || c.last_free < since) continue;
      for (int d = 0; d < dim_; ++d) {
        const auto idx = std::int64_t((k >> (21 * d)) & 0x1fffff) - (1 << 20);
        out.push_back((double(idx) + 0.5) * cell_);
      }
    }
    return out;
  }

 private:
  struct Cell {
    int last_hit = -1, free_after = 0, last_free = -1, hit_scans = 0;
  };
  std::uint64_t key(const double* x) const {
    std::uint64_t k = 0;
    for (int d = 0; d < dim_; ++d) {
      const auto i = std::int64_t(std::floor(x[d] / cell_)) + (1 << 20);
      k |= std::uint64_t(i & 0x1fffff) << (21 * d);
    }
    return k;
  }
  int dim_, stood_;
  double cell_;
  std::unordered_map<std::uint64_t, Cell> cells_;
};

void append(LabelledPoints& to, const LabelledPoints& from) {
  to.dim = from.dim;
  to.position.insert(to.position.end(), from.position.begin(), from.position.end());
  to.label.insert(to.label.end(), from.label.begin(), from.label.end());
}

// Mean probability and the fraction above 0.5 at `points` on an evaluator's map, accumulated.
struct LeftReading {
  double sum = 0, occupied = 0;
  std::size_t n = 0;
  void add(MapEvaluator& ev, const std::vector<double>& points) {
    if (points.empty()) return;
    for (float p : ev.evaluate(points).prob) {
      sum += p;
      occupied += p > 0.65f ? 1 : 0;
      ++n;
    }
  }
  double mean() const { return n ? sum / double(n) : 0; }
  double fraction() const { return n ? occupied / double(n) : 0; }
};

struct Row {
  double half_life = 0;
  Scores overall, now;
  LeftReading left, left_end;
  double ms_per_scan = 0, memory_mb = 0;
};

Scores scores_on(Context& ctx, const KernelMap& map, const LabelledPoints& test) {
  MapEvaluator ev(ctx, map);
  return score(ev.evaluate(test.position).prob, test.label);
}

// One half-life over the whole input.
Row run(Context& ctx, const Source& src, const Args& a, double half_life, double cell) {
  const double cut = a.range_cut > 0 ? a.range_cut : (src.dim == 3 ? 40 : 20);
  DriveMapperOptions dopt;
  dopt.range_cut = cut;
  dopt.bhm.half_life = half_life;
  std::unique_ptr<DriveMapper> drive;
  std::unique_ptr<JointBhm> bhm;
  JointBhmOptions bopt;
  bopt.half_life = half_life;
  if (src.dim == 3)
    drive = std::make_unique<DriveMapper>(dopt);
  else
    bhm = std::make_unique<JointBhm>(2, bopt);
  const LabelOptions labels = src.dim == 3 ? dopt.labels : LabelOptions{};
  LabelledPoints all_test, now_prob_labels;
  std::vector<float> now_prob;
  LeftPlaces left(src.dim, cell, a.stood);
  Row r;
  double ms = 0;
  for (std::size_t i = 0; i < src.count; ++i) {
    const Scan scan = limit_range(src.at(i), cut);
    const auto index = std::int64_t(src.first + i);
    LabelledSplit split;
    label_scan(scan, index, labels, split);
    split.train.dim = split.test.dim = src.dim;
    const auto t0 = std::chrono::steady_clock::now();
    if (drive) {
      drive->add(scan, index, &ctx);
    } else {
      bhm->set_time(scan.timestamp);
      bhm->update(split.train, &ctx);
    }
    ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    left.add(split.train, int(i));
    left.add(split.test, int(i));
    if (!drive) append(all_test, split.test);
    if (i % a.now_every == a.now_every - 1 && !split.test.empty()) {
      MapEvaluator ev(ctx, drive ? drive->map() : bhm->map());
      const MapValues v = ev.evaluate(split.test.position);
      now_prob.insert(now_prob.end(), v.prob.begin(), v.prob.end());
      append(now_prob_labels, split.test);
      r.left.add(ev, left.centres(int(i + 1 - a.now_every)));
    }
  }
  r.half_life = half_life;
  r.ms_per_scan = ms / double(std::max<std::size_t>(1, src.count));
  const KernelMap final_map = drive ? drive->map() : bhm->map();
  r.memory_mb = double(drive ? drive->memory_bytes() : bhm->memory_bytes()) / 1e6;
  r.overall = scores_on(ctx, final_map, drive ? drive->held_out() : all_test);
  if (!now_prob.empty()) r.now = score(now_prob, now_prob_labels.label);
  MapEvaluator ev(ctx, final_map);
  r.left_end.add(ev, left.centres());
  return r;
}

nlohmann::json to_json(const Scores& s) {
  return {{"acc", s.acc}, {"auc", s.auc}, {"nll", s.nll}, {"n", s.n}};
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  if (!parse(argc, argv, a)) {
    std::fprintf(stderr,
                 "usage: forgetting INPUT [--half-life 0,5,20] [--first N] [--max-scans N] "
                 "[--range-cut R] [--now-every K] [--stood S] [--cell C] [--json OUT]\n");
    return 2;
  }
  try {
    Context ctx;
    const Source src = open_source(a);
    if (src.count == 0) throw std::runtime_error(a.input + ": no scans");
    const double cell = a.cell > 0 ? a.cell : (src.dim == 3 ? 0.5 : 0.25);
    std::vector<Row> rows;
    for (double h : a.half_lives) {
      rows.push_back(run(ctx, src, a, h, cell));
      std::fprintf(stderr, "half-life %g s done (%.1f ms a scan)\n", h, rows.back().ms_per_scan);
    }
    std::printf(
        "%s: %zu scans from %zu (%dD); places left: %zu readings, %zu at the end "
        "(cells of %g m)\n",
        a.input.c_str(), src.count, src.first, src.dim, rows.front().left.n,
        rows.front().left_end.n, cell);
    std::printf("%-9s  %-16s %-16s %-16s %-16s %-8s %s\n", "half-life", "overall AUC/NLL",
                "now AUC/NLL", "left: p, p>0.65", "left at end", "ms/scan", "MB");
    nlohmann::json j = {{"input", a.input},
                        {"first", src.first},
                        {"scans", src.count},
                        {"dim", src.dim},
                        {"cell_m", cell},
                        {"now_every", a.now_every},
                        {"device", ctx.info().summary()}};
    for (const Row& r : rows) {
      std::printf("%-9g  %.4f / %.4f  %.4f / %.4f  %.3f, %5.1f %%   %.3f, %5.1f %%   %-8.1f %.1f\n",
                  r.half_life, r.overall.auc, r.overall.nll, r.now.auc, r.now.nll, r.left.mean(),
                  100 * r.left.fraction(), r.left_end.mean(), 100 * r.left_end.fraction(),
                  r.ms_per_scan, r.memory_mb);
      j["runs"].push_back({{"half_life_s", r.half_life},
                           {"overall", to_json(r.overall)},
                           {"now", to_json(r.now)},
                           {"left_readings", r.left.n},
                           {"left_mean_prob", r.left.mean()},
                           {"left_occupied_fraction", r.left.fraction()},
                           {"left_at_end", r.left_end.n},
                           {"left_at_end_mean_prob", r.left_end.mean()},
                           {"left_at_end_occupied_fraction", r.left_end.fraction()},
                           {"ms_per_scan", r.ms_per_scan},
                           {"memory_mb", r.memory_mb}});
    }
    std::ofstream(a.json) << j.dump(2) << "\n";
    std::printf("wrote %s\n", a.json.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "forgetting: %s\n", e.what());
    return 1;
  }
  return 0;
}
