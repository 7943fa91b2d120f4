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
//  - left: the final map's probability at the places the data say something left: a cell
//    (--cell metres) hit in some scan, then passed free by at least two later scans and never
//    hit again (a car that drove off, a door opened, a person gone); the mean probability there
//    and the fraction still read occupied (p > 0.5);
//  - ms per scan, and the learner's memory at the end.
// Prints a table, writes JSON.
//
// Usage: forgetting INPUT [--half-life 0,5,20] [--first 0] [--max-scans 0] [--range-cut R]
//                         [--now-every 10] [--cell C] [--json forgetting.json]
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
#include "potmap/learn/drive_mapper.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;

namespace {

struct Args {
  std::string input, json = "forgetting.json";
  std::vector<double> half_lives = {0, 5, 20};
  std::size_t first = 0, max_scans = 0, now_every = 10;
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
  explicit LeftPlaces(int dim, double cell) : dim_(dim), cell_(cell) {}
  void add(const LabelledPoints& p, int scan) {
    for (std::size_t i = 0; i < p.size(); ++i) {
      Cell& c = cells_[key(&p.position[i * std::size_t(dim_)])];
      if (p.label[i]) {
        c.last_hit = scan;
        c.free_after = 0;
      } else if (c.last_hit >= 0 && scan > c.last_hit && c.last_free != scan) {
        ++c.free_after;
        c.last_free = scan;
      }
    }
  }
  // The centres of the cells left.
  std::vector<double> centres() const {
    std::vector<double> out;
    for (const auto& [k, c] : cells_) {
      if (c.last_hit < 0 || c.free_after < 2) continue;
      for (int d = 0; d < dim_; ++d) {
        const auto idx = std::int64_t((k >> (21 * d)) & 0x1fffff) - (1 << 20);
        out.push_back((double(idx) + 0.5) * cell_);
      }
    }
    return out;
  }

 private:
  struct Cell {
    int last_hit = -1, free_after = 0, last_free = -1;
  };
  std::uint64_t key(const double* x) const {
    std::uint64_t k = 0;
    for (int d = 0; d < dim_; ++d) {
      const auto i = std::int64_t(std::floor(x[d] / cell_)) + (1 << 20);
      k |= std::uint64_t(i & 0x1fffff) << (21 * d);
    }
    return k;
  }
  int dim_;
  double cell_;
  std::unordered_map<std::uint64_t, Cell> cells_;
};

void append(LabelledPoints& to, const LabelledPoints& from) {
  to.dim = from.dim;
  to.position.insert(to.position.end(), from.position.begin(), from.position.end());
  to.label.insert(to.label.end(), from.label.begin(), from.label.end());
}

struct Row {
  double half_life = 0;
  Scores overall, now;
  double left_mean = 0, left_occupied = 0;
  std::size_t left = 0;
  double ms_per_scan = 0, memory_mb = 0;
};

Scores scores_on(Context& ctx, const KernelMap& map, const LabelledPoints& test) {
  MapEvaluator ev(ctx, map);
  return score(ev.evaluate(test.position).prob, test.label);
}

// One half-life over the whole input. `left` is filled on the first run (the data are the same
// for every half-life).
Row run(Context& ctx, const Source& src, const Args& a, double half_life, LeftPlaces* left,
        std::vector<double>& left_points) {
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
  LabelledPoints all_test, now_test, now_prob_labels;
  std::vector<float> now_prob;
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
    if (left) {
      left->add(split.train, int(i));
      left->add(split.test, int(i));
    }
    if (!drive) append(all_test, split.test);
    if (i % a.now_every == a.now_every - 1 && !split.test.empty()) {
      MapEvaluator ev(ctx, drive ? drive->map() : bhm->map());
      const MapValues v = ev.evaluate(split.test.position);
      now_prob.insert(now_prob.end(), v.prob.begin(), v.prob.end());
      append(now_prob_labels, split.test);
    }
  }
  Row r;
  r.half_life = half_life;
  r.ms_per_scan = ms / double(std::max<std::size_t>(1, src.count));
  const KernelMap final_map = drive ? drive->map() : bhm->map();
  r.memory_mb = double(drive ? drive->memory_bytes() : bhm->memory_bytes()) / 1e6;
  r.overall = scores_on(ctx, final_map, drive ? drive->held_out() : all_test);
  if (!now_prob.empty()) r.now = score(now_prob, now_prob_labels.label);
  if (left) left_points = left->centres();
  r.left = left_points.size() / std::size_t(src.dim);
  if (r.left > 0) {
    MapEvaluator ev(ctx, final_map);
    const MapValues v = ev.evaluate(left_points);
    for (float p : v.prob) {
      r.left_mean += p;
      r.left_occupied += p > 0.5f ? 1 : 0;
    }
    r.left_mean /= double(r.left);
    r.left_occupied /= double(r.left);
  }
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
                 "[--range-cut R] [--now-every K] [--cell C] [--json OUT]\n");
    return 2;
  }
  try {
    Context ctx;
    const Source src = open_source(a);
    if (src.count == 0) throw std::runtime_error(a.input + ": no scans");
    const double cell = a.cell > 0 ? a.cell : (src.dim == 3 ? 0.5 : 0.25);
    LeftPlaces left(src.dim, cell);
    std::vector<double> left_points;
    std::vector<Row> rows;
    for (std::size_t k = 0; k < a.half_lives.size(); ++k) {
      rows.push_back(run(ctx, src, a, a.half_lives[k], k == 0 ? &left : nullptr, left_points));
      const Row& r = rows.back();
      std::fprintf(stderr, "half-life %g s done (%.1f ms a scan)\n", r.half_life, r.ms_per_scan);
    }
    std::printf("%s: %zu scans from %zu (%dD), %zu places left (cells of %g m)\n", a.input.c_str(),
                src.count, src.first, src.dim, rows.front().left, cell);
    std::printf("%-10s %-15s %-15s %-20s %-10s %-9s\n", "half-life", "overall AUC/NLL",
                "now AUC/NLL", "left: mean p, p>0.5", "ms/scan", "MB");
    nlohmann::json j = {{"input", a.input},
                        {"first", src.first},
                        {"scans", src.count},
                        {"dim", src.dim},
                        {"cell_m", cell},
                        {"now_every", a.now_every},
                        {"device", ctx.info().summary()}};
    for (const Row& r : rows) {
      std::printf("%-10g %.4f / %.4f %.4f / %.4f %.3f, %5.1f %%      %-10.1f %-9.1f\n", r.half_life,
                  r.overall.auc, r.overall.nll, r.now.auc, r.now.nll, r.left_mean,
                  100 * r.left_occupied, r.ms_per_scan, r.memory_mb);
      j["runs"].push_back({{"half_life_s", r.half_life},
                           {"overall", to_json(r.overall)},
                           {"now", to_json(r.now)},
                           {"left_places", r.left},
                           {"left_mean_prob", r.left_mean},
                           {"left_occupied_fraction", r.left_occupied},
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
