#include "potmap/pot/mapper.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <memory>
#include <string>

#include "potmap/error.hpp"

namespace potmap {

namespace {

struct Prepared {
  PreparedTransfer transfer;
  LabelledPoints test;
  double time = 0;  // the scan's timestamp
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

Prepared prepare(Context* ctx, const Dictionary& dict, const Scan& scan, std::size_t i,
                 const MapperOptions& o, const std::vector<long>& warm) {
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
                                static_cast<std::int64_t>(i), o.pot, warm, ctx);
  // Labelling is host preparation too.
  p.transfer.timing.prepare_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  p.test = std::move(split.test);
  p.time = scan.timestamp;
  return p;
}

// The options with the dictionary's descriptors (pre-selection) or index (indexed ranking)
// built once when the ranking asks for them.
MapperOptions with_preselector(const Dictionary& dict, MapperOptions o) {
  if (o.pot.ranking == PotRanking::exhaustive && o.pot.candidates > 0 &&
      o.pot.candidates < dict.size() && !o.pot.preselector)
    o.pot.preselector = std::make_shared<const AtomPreselector>(dict);
  if (o.pot.ranking == PotRanking::indexed && !o.pot.index)
    o.pot.index = std::make_shared<const AtomIndex>(dict);
  return o;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// A scan ranked and transported (the device's part), its kernels not yet placed.
struct Solved {
  MappedScan scan;  // index, samples and the solve's wall time; no transfer yet
  SolvedTransfer transfer;
};

Solved solve(Context* ctx, const Dictionary& dict, Prepared&& cur, std::size_t i,
             const MapperOptions& o, const PotOptions& po) {
  const auto t0 = std::chrono::steady_clock::now();
  Solved s;
  s.scan.index = i;
  s.scan.time = cur.time;
  if (persistent_refine(o)) s.scan.train = cur.transfer.train;
  s.scan.test = std::move(cur.test);
  s.transfer = solve_transfer(ctx, dict, std::move(cur.transfer), po);
  s.scan.wall_ms = ms_since(t0);
  return s;
}

MappedScan place(Context* ctx, const Dictionary& dict, Solved&& s, const PotOptions& po) {
  const auto t0 = std::chrono::steady_clock::now();
  s.scan.transfer = place_transfer(ctx, dict, std::move(s.transfer), po);
  s.scan.wall_ms += ms_since(t0);
  return std::move(s.scan);
}

MappedScan finish(Context* ctx, const Dictionary& dict, Prepared&& cur, std::size_t i,
                  const MapperOptions& o, const PotOptions& po) {
  return place(ctx, dict, solve(ctx, dict, std::move(cur), i, o, po), po);
}

}  // namespace

MapperOptions MapperOptions::paper() {
  MapperOptions o;
  o.pot = PotOptions::paper();
  o.average_overall = false;
  // The authors' seeds: placed as the scan's kernels are, barycentric, with no variance added.
  o.seed_placement = o.pot.placement;
  o.seed_displacement_variance = 0;
  return o;
}

PotOptions mapper_transfer_options(const MapperOptions& o) {
  PotOptions p = o.pot;
  if (persistent_refine(o)) {  // the persistent map does RePOT's refinement; these only seed it
    p.refine = false;
    p.placement = o.seed_placement;
    p.displacement_variance = o.seed_displacement_variance;
  }
  return p;
}

void map_scans(Context* ctx, const Dictionary& dict, const std::vector<Scan>& scans,
               const MapperOptions& options, const std::function<void(MappedScan&&)>& on_scan) {
  map_scans(ctx, dict, scans, options, on_scan, MapScansStart{});
}

void map_scans(Context* ctx, const Dictionary& dict, const std::vector<Scan>& scans,
               const MapperOptions& options, const std::function<void(MappedScan&&)>& on_scan,
               const MapScansStart& start) {
  if (start.first >= scans.size()) return;
  const MapperOptions& o = with_preselector(dict, options);
  const PotOptions po = mapper_transfer_options(o);
  const auto launch = o.pipeline ? std::launch::async : std::launch::deferred;
  // Warm candidates: the atoms of the last scan finished when the next one is prepared (with
  // the pipeline, the scan before the one being solved; without, the same scan, so that both
  // give the same maps).
  std::vector<long> warm = start.warm_last;
  std::future<Prepared> next =
      std::async(launch, prepare, ctx, std::cref(dict), std::cref(scans[start.first]), start.first,
                 std::cref(o), start.warm_before);
  // With the pipeline, a scan's kernels are placed (host) beside the next scan's ranking and
  // transport (device): placement reads only the dictionary and its own solved transfer. Not
  // with the per-scan refinement, which uses the device too.
  const bool overlap = o.pipeline && !po.refine;
  std::future<MappedScan> placing;
  for (std::size_t i = start.first; i < scans.size(); ++i) {
    Prepared cur = next.get();
    if (i + 1 < scans.size())
      next = std::async(launch, prepare, ctx, std::cref(dict), std::cref(scans[i + 1]), i + 1,
                        std::cref(o), warm);
    Solved solved = solve(ctx, dict, std::move(cur), i, o, po);
    warm = chosen_atoms(solved.transfer);
    if (!overlap) {
      on_scan(place(ctx, dict, std::move(solved), po));
      continue;
    }
    std::future<MappedScan> placed = std::async(
        std::launch::async,
        [ctx, &dict, &po](Solved s) { return place(ctx, dict, std::move(s), po); },
        std::move(solved));
    if (placing.valid()) on_scan(placing.get());
    placing = std::move(placed);
  }
  if (placing.valid()) on_scan(placing.get());
}

RepotMap::RepotMap(int dim, const MapperOptions& options)
    : learner_(dim, options.refine_map), seed_min_variance_(options.seed_min_variance) {
  if (!(seed_min_variance_ >= 0) || !std::isfinite(seed_min_variance_))
    throw ArgumentError("RepotMap: seed_min_variance must be >= 0 and finite");
}

std::size_t RepotMap::add(const KernelMap& transported, const LabelledPoints& train, Context* ctx,
                          double time) {
  export_.reset();
  if (std::isfinite(time)) learner_.set_time(time);
  std::size_t seeded = 0;
  if (!transported.empty()) seeded = learner_.seed_unreached(transported, seed_min_variance_);
  learner_.update(train, ctx);
  return seeded;
}

const KernelMap& RepotMap::map() const {
  if (!export_) export_ = learner_.map();
  return *export_;
}

std::size_t RepotMap::memory_bytes() const {
  std::size_t b = learner_.memory_bytes();
  if (export_)
    b += 8 * (export_->position.capacity() + export_->gamma.capacity() +
              export_->w_mean.capacity() + export_->w_var.capacity());
  return b;
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
  if (persistent_refine(options_))
    repot_.emplace(dict_->dim, options_);
  else if (options_.average_overall)
    averaged_.emplace(dict_->dim, options_.averaged);
  last_.transfer.map.dim = last_.test.dim = last_.train.dim = dict_->dim;
}

const MappedScan& Mapper::add_scan(const Scan& scan) {
  // The preparation and the transfer read the dictionary, the options, the scan count and the
  // warm candidates, never the overall map: they run beside the previous scan's merge.
  Prepared cur = prepare(ctx_, *dict_, scan, scans_, options_, warm_[1]);
  MappedScan m =
      finish(ctx_, *dict_, std::move(cur), scans_, options_, mapper_transfer_options(options_));
  if (!options_.async_merge) {
    add_mapped(std::move(m));
    return last_;
  }
  settle();
  warm_[0] = std::move(warm_[1]);
  warm_[1] = chosen_atoms(m.transfer);
  last_ = std::move(m);
  ++scans_;
  // The merge reads last_ (which the caller may read too, never write) and writes the maps and
  // merge_, which every accessor reads only after settle().
  merging_.start(std::async(std::launch::async, [this] {
    MapperMerge merge;
    merge_scan(last_, merge, false);
    merge_ = merge;
  }));
  return last_;
}

Mapper::~Mapper() {
  merging_.wait();  // before the maps the merge writes are destroyed
}

void Mapper::settle() const {
  merging_.settle();
}

void Mapper::merge_scan(MappedScan& m, MapperMerge& merge, bool refine_into_scan) {
  const auto t1 = std::chrono::steady_clock::now();
  if (repot_) {
    merge.seeded =
        repot_->add(m.transfer.map, m.train, options_.refine_on_host_team ? ctx_ : nullptr, m.time);
    if (refine_into_scan)
      m.transfer.timing.refine_ms += ms_since(t1);
    else
      merge.merge_ms = ms_since(t1);
  } else {
    if (averaged_)
      averaged_->add(m.transfer.map);
    else if (!m.transfer.map.empty())
      merge.stats = overall_.add(m.transfer.map);
    merge.merge_ms = ms_since(t1);
  }
}

const MapperMerge& Mapper::add_mapped(MappedScan&& m) {
  settle();
  if (m.index != scans_)
    throw ArgumentError("Mapper::add_mapped: scan " + std::to_string(m.index) +
                        " given, the mapper expects scan " + std::to_string(scans_));
  if (m.transfer.map.dim != dict_->dim)
    throw ArgumentError("Mapper::add_mapped: scan " + std::to_string(m.index) + " is " +
                        std::to_string(m.transfer.map.dim) + "D, the dictionary " +
                        std::to_string(dict_->dim) + "D");
  MapperMerge merge;
  merge_scan(m, merge, true);
  warm_[0] = std::move(warm_[1]);
  warm_[1] = chosen_atoms(m.transfer);
  last_ = std::move(m);
  merge_ = merge;
  ++scans_;
  return merge_;
}

MapScansStart Mapper::continuation() const {
  MapScansStart s;
  s.first = scans_;
  s.warm_before = warm_[0];
  s.warm_last = warm_[1];
  return s;
}

void Mapper::start_at(std::size_t index) {
  settle();
  if (scans_ != 0)
    throw ArgumentError("Mapper::start_at: the mapper already has " + std::to_string(scans_) +
                        " scans; a part starts on an empty mapper");
  scans_ = index;
  last_.index = index > 0 ? index - 1 : 0;
}

const KernelMap& Mapper::overall_map() const {
  settle();
  return repot_ ? repot_->map() : averaged_ ? averaged_->map() : overall_.map();
}

std::size_t Mapper::overall_kernels() const {
  settle();
  return repot_ ? repot_->size() : averaged_ ? averaged_->size() : overall_.size();
}

std::size_t Mapper::overall_memory_bytes() const {
  settle();
  return repot_      ? repot_->memory_bytes()
         : averaged_ ? averaged_->memory_bytes()
                     : overall_.memory_bytes();
}

void Mapper::reset() {
  merging_.forget();
  overall_ = OverallMap(dict_->dim, overall_.options());
  if (repot_) repot_.emplace(dict_->dim, options_);
  if (averaged_) averaged_.emplace(dict_->dim, options_.averaged);
  last_ = MappedScan();
  last_.transfer.map.dim = last_.test.dim = last_.train.dim = dict_->dim;
  merge_ = MapperMerge();
  scans_ = 0;
  warm_[0].clear();
  warm_[1].clear();
}

}  // namespace potmap
