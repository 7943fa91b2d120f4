// C API: POT / RePOT mappers fed one scan at a time, with their instantaneous and overall maps.
#include <chrono>
#include <cmath>
#include <memory>
#include <string>

#include "capi_handles.hpp"
#include "capi_structs.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/mapping/map_files.hpp"

namespace potmap::capi {
namespace {

constexpr int kMaxRotations = 3600;    // 0.1 degree steps: beyond, a typo rather than a choice
constexpr int kMaxEmIterations = 100;  // each a solve per scan: beyond, a typo rather than a choice

// The C placement of `m`'s two placements (the scans' kernels, RePOT's persistent seeds).
int c_placement(const potmap::MapperOptions& m) {
  using potmap::PotPlacement;
  if (m.pot.placement == PotPlacement::target_samples &&
      m.seed_placement == PotPlacement::barycentric)
    return POTMAP_PLACEMENT_AUTO;
  return m.pot.placement == PotPlacement::target_samples ? POTMAP_PLACEMENT_TARGET_SAMPLES
                                                         : POTMAP_PLACEMENT_BARYCENTRIC;
}

// `m` in the C struct (the overall map's options: OverallMapOptions{}).
potmap_mapper_options c_options(const potmap::MapperOptions& m) {
  const potmap::OverallMapOptions ov;
  potmap_mapper_options o{};
  o.struct_size = sizeof o;
  o.sectors = m.pot.sectors;
  o.rotations = static_cast<int>(m.pot.rotations.size());
  o.refine = m.pot.refine ? 1 : 0;
  o.max_range = m.pot.max_range;
  o.candidates = m.pot.candidates;
  o.holdout_fraction = m.labels.holdout_fraction;
  o.free_per_metre = m.labels.free_per_metre;
  o.seed = m.pot.seed;
  o.merge_radius = ov.merge_radius;
  o.gamma_ratio = ov.gamma_ratio;
  o.max_kernels = ov.max_kernels;
  o.persistent_refine = m.persistent_refine ? 1 : 0;
  o.ranking = m.pot.ranking == potmap::PotRanking::indexed ? POTMAP_RANKING_INDEXED
                                                           : POTMAP_RANKING_EXHAUSTIVE;
  o.placement = c_placement(m);
  o.anchor_spacing = m.pot.anchor_spacing;
  o.wall_clearance = m.pot.wall_clearance;
  o.average_overall = m.average_overall ? 1 : 0;
  o.async_merge = m.async_merge ? 1 : 0;
  o.seeds_yield_fully = m.refine_map.seeds_yield_fully ? 1 : 0;
  o.refine_spacing = m.refine_map.spacing;
  o.refine_prior_var = m.refine_map.prior_var;
  o.refine_em_iterations = m.refine_map.em_iterations;
  o.seed_displacement_variance = m.seed_displacement_variance;
  o.half_life = m.refine_map.half_life;
  o.anchor_clearance = m.pot.anchor_clearance;
  o.anchor_sweeps = m.pot.anchor_sweeps;
  o.logit_gain = m.pot.logit_gain;
  return o;
}

potmap_mapper_options default_mapper_options() {
  return c_options(potmap::MapperOptions{});
}

// tools/cmd_map.cpp's defaults for the fields the C API has: the library's, with its seeds.
potmap_mapper_options map_default_options() {
  potmap_mapper_options o = default_mapper_options();
  o.seed_displacement_variance = 0;
  return o;
}

struct Options {
  potmap::MapperOptions mapper;
  potmap::OverallMapOptions overall;
};

Options to_options(const potmap_mapper_options* in) {
  const potmap_mapper_options o =
      in ? read_struct(in, default_mapper_options(), kMapperOptionsV1, "options")
         : default_mapper_options();
  auto bad = [](const std::string& field, double v) {
    fail(POTMAP_ERROR_INVALID_ARGUMENT,
         "options->" + field + " is out of range: " + std::to_string(v));
  };
  if (o.sectors < 1) bad("sectors", o.sectors);
  if (o.rotations < 1 || o.rotations > kMaxRotations) bad("rotations", o.rotations);
  if (o.refine != 0 && o.refine != 1) bad("refine", o.refine);
  if (o.persistent_refine != 0 && o.persistent_refine != 1)
    bad("persistent_refine", o.persistent_refine);
  if (!(o.max_range >= 0) || !std::isfinite(o.max_range)) bad("max_range", o.max_range);
  if (!(o.holdout_fraction >= 0 && o.holdout_fraction < 1))
    bad("holdout_fraction", o.holdout_fraction);
  if (!(o.free_per_metre > 0) || !std::isfinite(o.free_per_metre))
    bad("free_per_metre", o.free_per_metre);
  if (!(o.merge_radius >= 0) || !std::isfinite(o.merge_radius)) bad("merge_radius", o.merge_radius);
  if (!(o.gamma_ratio >= 1) || !std::isfinite(o.gamma_ratio)) bad("gamma_ratio", o.gamma_ratio);
  if (o.ranking != POTMAP_RANKING_EXHAUSTIVE && o.ranking != POTMAP_RANKING_INDEXED)
    bad("ranking", o.ranking);
  if (o.placement < POTMAP_PLACEMENT_BARYCENTRIC || o.placement > POTMAP_PLACEMENT_AUTO)
    bad("placement", o.placement);
  if (!(o.anchor_spacing > 0) || !std::isfinite(o.anchor_spacing))
    bad("anchor_spacing", o.anchor_spacing);
  if (!(o.wall_clearance >= 0) || !std::isfinite(o.wall_clearance))
    bad("wall_clearance", o.wall_clearance);
  if (o.average_overall != 0 && o.average_overall != 1) bad("average_overall", o.average_overall);
  if (o.async_merge != 0 && o.async_merge != 1) bad("async_merge", o.async_merge);
  if (o.seeds_yield_fully != 0 && o.seeds_yield_fully != 1)
    bad("seeds_yield_fully", o.seeds_yield_fully);
  if (!(o.refine_spacing > 0) || !std::isfinite(o.refine_spacing))
    bad("refine_spacing", o.refine_spacing);
  if (!(o.refine_prior_var > 0) || !std::isfinite(o.refine_prior_var))
    bad("refine_prior_var", o.refine_prior_var);
  if (o.refine_em_iterations < 1 || o.refine_em_iterations > kMaxEmIterations)
    bad("refine_em_iterations", o.refine_em_iterations);
  if (!(o.seed_displacement_variance >= 0) || !std::isfinite(o.seed_displacement_variance))
    bad("seed_displacement_variance", o.seed_displacement_variance);
  if (!(o.half_life >= 0) || !std::isfinite(o.half_life)) bad("half_life", o.half_life);
  if (!(o.anchor_clearance >= 0) || !std::isfinite(o.anchor_clearance))
    bad("anchor_clearance", o.anchor_clearance);
  if (o.anchor_sweeps < 0) bad("anchor_sweeps", o.anchor_sweeps);
  if (!(o.logit_gain > 0) || !std::isfinite(o.logit_gain)) bad("logit_gain", o.logit_gain);
  Options r;
  potmap::PotOptions& p = r.mapper.pot;
  p.sectors = o.sectors;
  p.rotations = potmap::evenly_spaced_rotations(o.rotations);
  p.refine = o.refine == 1;
  r.mapper.persistent_refine = o.persistent_refine == 1;
  p.ranking = o.ranking == POTMAP_RANKING_INDEXED ? potmap::PotRanking::indexed
                                                  : potmap::PotRanking::exhaustive;
  // AUTO: kernels on the samples, RePOT's persistent seeds barycentric; otherwise both alike.
  p.placement = o.placement == POTMAP_PLACEMENT_BARYCENTRIC ? potmap::PotPlacement::barycentric
                                                            : potmap::PotPlacement::target_samples;
  r.mapper.seed_placement = o.placement == POTMAP_PLACEMENT_TARGET_SAMPLES
                                ? potmap::PotPlacement::target_samples
                                : potmap::PotPlacement::barycentric;
  r.mapper.seed_displacement_variance = o.seed_displacement_variance;
  p.anchor_spacing = o.anchor_spacing;
  p.wall_clearance = o.wall_clearance;
  p.anchor_clearance = o.anchor_clearance;
  p.anchor_sweeps = o.anchor_sweeps;
  p.logit_gain = o.logit_gain;
  r.mapper.average_overall = o.average_overall == 1;
  r.mapper.async_merge = o.async_merge == 1;
  r.mapper.refine_map.seeds_yield_fully = o.seeds_yield_fully == 1;
  r.mapper.refine_map.spacing = o.refine_spacing;
  r.mapper.refine_map.prior_var = o.refine_prior_var;
  r.mapper.refine_map.em_iterations = o.refine_em_iterations;
  r.mapper.refine_map.half_life = o.half_life;
  p.max_range = o.max_range;
  p.candidates = o.candidates;
  p.seed = o.seed;
  r.mapper.labels.holdout_fraction = o.holdout_fraction;
  r.mapper.labels.free_per_metre = o.free_per_metre;
  r.mapper.labels.seed = o.seed;
  r.mapper.pipeline = false;
  r.overall.merge_radius = o.merge_radius;
  r.overall.gamma_ratio = o.gamma_ratio;
  r.overall.max_kernels = o.max_kernels;
  return r;
}

potmap_map* copy_map(const potmap::KernelMap& m) {
  auto h = std::make_unique<potmap_map>();
  h->map = m;
  return h.release();
}

}  // namespace
}  // namespace potmap::capi

using namespace potmap::capi;

extern "C" {

potmap_status potmap_mapper_options_init(potmap_mapper_options* options, size_t struct_size) {
  return guard("potmap_mapper_options_init", POTMAP_ERROR_INTERNAL, [&] {
    init_struct(options, struct_size, default_mapper_options(), kMapperOptionsV1, "options");
  });
}

potmap_status potmap_mapper_options_init_paper(potmap_mapper_options* options, size_t struct_size) {
  return guard("potmap_mapper_options_init_paper", POTMAP_ERROR_INTERNAL, [&] {
    init_struct(options, struct_size, c_options(potmap::MapperOptions::paper()), kMapperOptionsV1,
                "options");
  });
}

potmap_status potmap_mapper_options_init_map_defaults(potmap_mapper_options* options,
                                                      size_t struct_size) {
  return guard("potmap_mapper_options_init_map_defaults", POTMAP_ERROR_INTERNAL, [&] {
    init_struct(options, struct_size, map_default_options(), kMapperOptionsV1, "options");
  });
}

potmap_status potmap_mapper_create(potmap_context* context, const potmap_dictionary* dictionary,
                                   const potmap_mapper_options* options, potmap_mapper** out) {
  return guard("potmap_mapper_create", POTMAP_ERROR_INTERNAL, [&] {
    potmap_context& c = checked(context);
    const potmap_dictionary& d = checked(dictionary);
    require(out, "out");
    const Options o = to_options(options);
    auto h = std::make_unique<potmap_mapper>();
    h->ctx = c.ctx;
    h->mapper = std::make_unique<potmap::Mapper>(h->ctx.get(), d.dict, o.mapper, o.overall);
    *out = h.release();
  });
}

potmap_status potmap_mapper_destroy(potmap_mapper* mapper) {
  return destroy(mapper, kMapperTag, "potmap_mapper_destroy");
}

potmap_status potmap_mapper_add_scan(potmap_mapper* mapper, const potmap_scan* scan,
                                     potmap_scan_stats* stats) {
  return guard("potmap_mapper_add_scan", POTMAP_ERROR_INTERNAL, [&] {
    potmap::Mapper& m = *checked(mapper).mapper;
    const auto t0 = std::chrono::steady_clock::now();
    // Checked before any work, so that a bad stats struct leaves the mapper unchanged.
    if (stats)
      check_struct_size(stats->struct_size, kScanStatsV1, "stats", POTMAP_ERROR_BUFFER_TOO_SMALL);
    const potmap::Scan s = to_scan(scan, "scan");
    if (s.dim != m.dictionary().dim)
      fail(POTMAP_ERROR_DIMENSION_MISMATCH, "the scan is " + std::to_string(s.dim) +
                                                "D, the mapper's dictionary " +
                                                std::to_string(m.dictionary().dim) + "D");
    const potmap::MappedScan& r = m.add_scan(s);
    if (!stats) return;
    const potmap::ScanTransfer& t = r.transfer;
    const potmap::MapperMerge& mg = m.last_merge();
    potmap_scan_stats st{};
    st.scan_index = r.index;
    for (const potmap::SectorTransfer& sec : t.sectors) {
      st.sectors += sec.atom >= 0;
      st.kernels_dropped += sec.kernels_dropped;
      st.train_samples += sec.target_hits + sec.target_free;
    }
    st.kernels_placed = t.map.size();
    st.heldout_samples = r.test.size();
    st.overall_added = mg.stats.added;
    st.overall_merged = mg.stats.merged;
    st.overall_retired = mg.stats.retired;
    st.overall_kernels = m.overall_kernels();
    st.prepare_ms = t.timing.prepare_ms;
    st.ranking_ms = t.timing.ranking_ms;
    st.transport_ms = t.timing.transport_ms;
    st.placement_ms = t.timing.placement_ms;
    st.refine_ms = t.timing.refine_ms;
    st.merge_ms = mg.merge_ms;
    st.total_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    write_struct(stats, st, kScanStatsV1, "stats", POTMAP_ERROR_BUFFER_TOO_SMALL);
  });
}

potmap_status potmap_mapper_instantaneous_map(const potmap_mapper* mapper, potmap_map** out) {
  return guard("potmap_mapper_instantaneous_map", POTMAP_ERROR_INTERNAL, [&] {
    const potmap::Mapper& m = *checked(mapper).mapper;
    require(out, "out");
    *out = copy_map(m.last().transfer.map);
  });
}

potmap_status potmap_mapper_overall_map(const potmap_mapper* mapper, potmap_map** out) {
  return guard("potmap_mapper_overall_map", POTMAP_ERROR_INTERNAL, [&] {
    const potmap::Mapper& m = *checked(mapper).mapper;
    require(out, "out");
    *out = copy_map(m.overall_map());
  });
}

potmap_status potmap_mapper_save_overall_map(const potmap_mapper* mapper, const char* path) {
  return guard("potmap_mapper_save_overall_map", POTMAP_ERROR_IO, [&] {
    const potmap::Mapper& m = *checked(mapper).mapper;
    require(path, "path");
    potmap::write_mapper_map(m, path);
  });
}

potmap_status potmap_mapper_reset(potmap_mapper* mapper) {
  return guard("potmap_mapper_reset", POTMAP_ERROR_INTERNAL,
               [&] { checked(mapper).mapper->reset(); });
}

potmap_status potmap_mapper_save_state(const potmap_mapper* mapper, const char* path) {
  return guard("potmap_mapper_save_state", POTMAP_ERROR_IO, [&] {
    const potmap::Mapper& m = *checked(mapper).mapper;
    require(path, "path");
    m.save_state(path);
  });
}

potmap_status potmap_mapper_load_state(potmap_mapper* mapper, const char* path) {
  return guard("potmap_mapper_load_state", POTMAP_ERROR_INPUT, [&] {
    potmap::Mapper& m = *checked(mapper).mapper;
    require(path, "path");
    m.load_state(path);
  });
}

}  // extern "C"
