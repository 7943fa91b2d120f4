#include "potmap/mapper.hpp"

#include <algorithm>
#include <chrono>
#include <future>
#include <memory>
#include <string>

#include "potmap/error.hpp"

namespace potmap {

namespace {

struct Prepared {
  PreparedTransfer transfer;
  LabelledPoints test;
};

void within_range(LabelledPoints& lp, const std::array<double, 3>& sensor, double range) {
  const int d = lp.dim;
  const double r2 = range * range;
  std::size_t k = 0;
  for (std::size_t i = 0; i < lp.size(); ++i) {
    const double dx = lp.position[i * d] - sensor[0], dy = lp.position[i * d + 1] - sensor[1];
    if (dx * dx + dy * dy > r2) continue;
    std::copy(&lp.position[i * d], &lp.position[i * d] + d, &lp.position[k * d]);
    lp.label[k] = lp.label[i];
    lp.scan[k] = lp.scan[i];
    ++k;
  }
  lp.position.resize(k * d);
  lp.label.resize(k);
  lp.scan.resize(k);
}

Prepared prepare(const Dictionary& dict, const Scan& scan, std::size_t i, const MapperOptions& o) {
  if (scan.dim != dict.dim)
    throw ArgumentError("mapper: scan " + std::to_string(i) + " is " + std::to_string(scan.dim) +
                        "D, the dictionary " + std::to_string(dict.dim) + "D");
  const auto t0 = std::chrono::steady_clock::now();
  LabelledSplit split;
  label_scan(scan, static_cast<std::int64_t>(i), o.labels, split);
  split.train.dim = split.test.dim = scan.dim;
  // Samples beyond the sector radius can be neither transported nor refined, and no kernel
  // reaches them: a long-range sensor (KITTI's 120 m) would only pay for them.
  const double range = o.pot.max_range > 0 ? o.pot.max_range : dict.max_range;
  const auto sensor = scan.origin();
  within_range(split.train, sensor, range);
  within_range(split.test, sensor, range);
  Prepared p;
  p.transfer = prepare_transfer(dict, std::move(split.train), scan.origin(), scan_heading(scan),
                                static_cast<std::int64_t>(i), o.pot);
  // Labelling is host preparation too.
  p.transfer.timing.prepare_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  p.test = std::move(split.test);
  return p;
}

// The options with the dictionary's descriptors built once when pre-selection asks for them.
MapperOptions with_preselector(const Dictionary& dict, MapperOptions o) {
  if (o.pot.candidates > 0 && o.pot.candidates < dict.size() && !o.pot.preselector)
    o.pot.preselector = std::make_shared<const AtomPreselector>(dict);
  return o;
}

}  // namespace

void map_scans(Context* ctx, const Dictionary& dict, const std::vector<Scan>& scans,
               const MapperOptions& options, const std::function<void(MappedScan&&)>& on_scan) {
  if (scans.empty()) return;
  const MapperOptions& o = with_preselector(dict, options);
  const auto launch = o.pipeline ? std::launch::async : std::launch::deferred;
  std::future<Prepared> next = std::async(launch, prepare, std::cref(dict), std::cref(scans[0]),
                                          std::size_t{0}, std::cref(o));
  for (std::size_t i = 0; i < scans.size(); ++i) {
    Prepared cur = next.get();
    if (i + 1 < scans.size())
      next = std::async(launch, prepare, std::cref(dict), std::cref(scans[i + 1]), i + 1,
                        std::cref(o));
    const auto t0 = std::chrono::steady_clock::now();
    MappedScan m;
    m.index = i;
    m.transfer = finish_transfer(ctx, dict, std::move(cur.transfer), o.pot);
    m.test = std::move(cur.test);
    m.wall_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    on_scan(std::move(m));
  }
}

Mapper::Mapper(Context* ctx, std::shared_ptr<const Dictionary> dict, const MapperOptions& options,
               const OverallMapOptions& overall)
    : ctx_(ctx),
      dict_(std::move(dict)),
      options_(options),
      overall_(dict_ ? dict_->dim : 2, overall) {
  if (!dict_) throw ArgumentError("Mapper: the dictionary is null");
  if (dict_->empty()) throw ArgumentError("Mapper: the dictionary has no atoms");
  options_ = with_preselector(*dict_, options_);
  last_.transfer.map.dim = last_.test.dim = dict_->dim;
}

const MappedScan& Mapper::add_scan(const Scan& scan) {
  Prepared cur = prepare(*dict_, scan, scans_, options_);
  const auto t0 = std::chrono::steady_clock::now();
  MappedScan m;
  m.index = scans_;
  m.transfer = finish_transfer(ctx_, *dict_, std::move(cur.transfer), options_.pot);
  m.test = std::move(cur.test);
  m.wall_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const auto t1 = std::chrono::steady_clock::now();
  MapperMerge merge;
  if (!m.transfer.map.empty()) merge.stats = overall_.add(m.transfer.map);
  merge.merge_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
  last_ = std::move(m);
  merge_ = merge;
  ++scans_;
  return last_;
}

void Mapper::reset() {
  overall_ = OverallMap(dict_->dim, overall_.options());
  last_ = MappedScan();
  last_.transfer.map.dim = last_.test.dim = dict_->dim;
  merge_ = MapperMerge();
  scans_ = 0;
}

}  // namespace potmap
