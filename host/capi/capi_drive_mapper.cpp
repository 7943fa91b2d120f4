// C API: the joint BHM over a 3D drive, a keyframe at a time (learn/drive_mapper.hpp).
#include <cmath>
#include <memory>
#include <string>

#include "capi_handles.hpp"
#include "capi_structs.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/learn/bhm_joint_merge.hpp"

namespace potmap::capi {
namespace {

static_assert(int(potmap::JointBhmSums::automatic) == POTMAP_SUMS_AUTOMATIC &&
                  int(potmap::JointBhmSums::host) == POTMAP_SUMS_HOST &&
                  int(potmap::JointBhmSums::device) == POTMAP_SUMS_DEVICE,
              "potmap_sums follows JointBhmSums");

potmap_drive_mapper_options default_options() {
  const potmap::DriveMapperOptions d;
  potmap_drive_mapper_options o{};
  o.struct_size = sizeof o;
  o.range_cut = d.range_cut;
  o.free_per_metre = d.labels.free_per_metre;
  o.holdout_fraction = d.labels.holdout_fraction;
  o.seed = d.labels.seed;
  o.voxel = d.voxel;
  o.retire_radius = d.retire_radius;
  o.transfer_every = d.transfer_every;
  o.sums = int(d.bhm.sums);
  o.half_life = d.bhm.half_life;
  o.lookahead = d.lookahead;
  return o;
}

potmap::DriveMapperOptions to_options(const potmap_drive_mapper_options* in) {
  const potmap_drive_mapper_options o =
      in ? read_struct(in, default_options(), kDriveMapperOptionsV1, "options") : default_options();
  auto bad = [](const std::string& field, double v) {
    fail(POTMAP_ERROR_INVALID_ARGUMENT,
         "options->" + field + " is out of range: " + std::to_string(v));
  };
  if (!(o.range_cut > 0) || !std::isfinite(o.range_cut)) bad("range_cut", o.range_cut);
  if (!(o.free_per_metre > 0) || !std::isfinite(o.free_per_metre))
    bad("free_per_metre", o.free_per_metre);
  if (!(o.holdout_fraction >= 0 && o.holdout_fraction < 1))
    bad("holdout_fraction", o.holdout_fraction);
  if (!(o.voxel >= 0) || !std::isfinite(o.voxel)) bad("voxel", o.voxel);
  if (!(o.retire_radius >= -1) || !std::isfinite(o.retire_radius))
    bad("retire_radius", o.retire_radius);
  if (o.transfer_every < 1) bad("transfer_every", double(o.transfer_every));
  if (o.sums < POTMAP_SUMS_AUTOMATIC || o.sums > POTMAP_SUMS_DEVICE) bad("sums", double(o.sums));
  if (!(o.half_life >= 0) || !std::isfinite(o.half_life)) bad("half_life", o.half_life);
  potmap::DriveMapperOptions r;
  r.range_cut = o.range_cut;
  r.labels.free_per_metre = o.free_per_metre;
  r.labels.holdout_fraction = o.holdout_fraction;
  r.labels.seed = o.seed;
  r.voxel = o.voxel;
  r.retire_radius = o.retire_radius < 0 ? -1 : o.retire_radius;
  r.transfer_every = o.transfer_every;
  r.bhm.sums = static_cast<potmap::JointBhmSums>(o.sums);
  r.bhm.half_life = o.half_life;
  r.lookahead = o.lookahead != 0;
  return r;
}

}  // namespace
}  // namespace potmap::capi

using namespace potmap::capi;

extern "C" {

potmap_status potmap_drive_mapper_options_init(potmap_drive_mapper_options* options,
                                               size_t struct_size) {
  return guard("potmap_drive_mapper_options_init", POTMAP_ERROR_INTERNAL, [&] {
    init_struct(options, struct_size, default_options(), kDriveMapperOptionsV1, "options");
  });
}

potmap_status potmap_drive_mapper_create(potmap_context* context,
                                         const potmap_drive_mapper_options* options,
                                         potmap_drive_mapper** out) {
  return guard("potmap_drive_mapper_create", POTMAP_ERROR_INTERNAL, [&] {
    require(out, "out");
    auto h = std::make_unique<potmap_drive_mapper>();
    if (context) h->ctx = checked(context).ctx;
    h->mapper = std::make_unique<potmap::DriveMapper>(to_options(options));
    *out = h.release();
  });
}

potmap_status potmap_drive_mapper_create_repot(potmap_context* context,
                                               const potmap_drive_mapper_options* options,
                                               const potmap_dictionary* dictionary,
                                               potmap_drive_mapper** out) {
  return guard("potmap_drive_mapper_create_repot", POTMAP_ERROR_INTERNAL, [&] {
    require(out, "out");
    const potmap_dictionary& d = checked(dictionary);
    if (d.dict->dim != 3)
      fail(POTMAP_ERROR_DIMENSION_MISMATCH,
           "the dictionary is " + std::to_string(d.dict->dim) + "D, a drive needs 3D atoms");
    potmap::DriveMapperOptions o = to_options(options);
    o.dictionary = d.dict;
    auto h = std::make_unique<potmap_drive_mapper>();
    if (context) h->ctx = checked(context).ctx;
    h->mapper = std::make_unique<potmap::DriveMapper>(o);
    *out = h.release();
  });
}

potmap_status potmap_drive_mapper_lookahead(const potmap_drive_mapper* mapper, double* auc,
                                            double* nll, size_t* n, double* beyond_auc,
                                            double* beyond_nll, size_t* beyond_n) {
  return guard("potmap_drive_mapper_lookahead", POTMAP_ERROR_INTERNAL, [&] {
    const potmap_drive_mapper& h = checked(mapper);
    potmap::Scores all, beyond;
    potmap::lookahead_scores(h.mapper->lookahead(), all, beyond);
    if (auc) *auc = all.auc;
    if (nll) *nll = all.nll;
    if (n) *n = all.n;
    if (beyond_auc) *beyond_auc = beyond.auc;
    if (beyond_nll) *beyond_nll = beyond.nll;
    if (beyond_n) *beyond_n = beyond.n;
  });
}

potmap_status potmap_drive_mapper_destroy(potmap_drive_mapper* mapper) {
  return destroy(mapper, kDriveMapperTag, "potmap_drive_mapper_destroy");
}

potmap_status potmap_drive_mapper_add_keyframe(potmap_drive_mapper* mapper,
                                               const potmap_scan* keyframe, int64_t index,
                                               potmap_keyframe_stats* stats) {
  return guard("potmap_drive_mapper_add_keyframe", POTMAP_ERROR_INTERNAL, [&] {
    potmap_drive_mapper& h = checked(mapper);
    if (stats)
      check_struct_size(stats->struct_size, kKeyframeStatsV1, "stats",
                        POTMAP_ERROR_BUFFER_TOO_SMALL);
    const potmap::Scan s = to_scan(keyframe, "keyframe");
    if (s.dim != 3)
      fail(POTMAP_ERROR_DIMENSION_MISMATCH,
           "the keyframe is " + std::to_string(s.dim) + "D, a drive's are 3D");
    const potmap::KeyframeStats k = h.mapper->add(s, index, h.ctx.get());
    if (!stats) return;
    potmap_keyframe_stats st{};
    st.samples = k.samples;
    st.gathered = k.gathered;
    st.held_out = k.held_out;
    st.retired = k.retired;
    st.memory_bytes = k.memory_bytes;
    st.label_ms = k.label_ms;
    st.update_ms = k.update_ms;
    st.transfer_ms = k.transfer_ms;
    st.seeded = k.seeded;
    st.sums_on_device = k.sums_on_device ? 1 : 0;
    st.lookahead_ms = k.lookahead_ms;
    write_struct(stats, st, kKeyframeStatsV1, "stats", POTMAP_ERROR_BUFFER_TOO_SMALL);
  });
}

potmap_status potmap_drive_mapper_map(const potmap_drive_mapper* mapper, potmap_map** out) {
  return guard("potmap_drive_mapper_map", POTMAP_ERROR_INTERNAL, [&] {
    const potmap_drive_mapper& h = checked(mapper);
    require(out, "out");
    auto m = std::make_unique<potmap_map>();
    m->map = h.mapper->map(h.ctx.get());
    *out = m.release();
  });
}

potmap_status potmap_drive_mapper_save_map(const potmap_drive_mapper* mapper, const char* path) {
  return guard("potmap_drive_mapper_save_map", POTMAP_ERROR_IO, [&] {
    const potmap::DriveMapper& m = *checked(mapper).mapper;
    require(path, "path");
    // A retired tile's couplings went into its neighbours' eta: no exact information form.
    if (m.learner().retired_tiles() == 0 && potmap::capi::is_potmap_file(path))
      potmap::write_joint_bhm_map(m.learner(), path);
    else
      potmap::write_map(m.map(), path);
  });
}

potmap_status potmap_drive_mapper_held_out(const potmap_drive_mapper* mapper, size_t* n,
                                           const double** positions, const uint8_t** labels) {
  return guard("potmap_drive_mapper_held_out", POTMAP_ERROR_INTERNAL, [&] {
    const potmap::LabelledPoints& t = checked(mapper).mapper->held_out();
    require(n, "n");
    require(positions, "positions");
    require(labels, "labels");
    *n = t.size();
    *positions = t.position.data();
    *labels = t.label.data();
  });
}

potmap_status potmap_drive_mapper_save_state(const potmap_drive_mapper* mapper, const char* path) {
  return guard("potmap_drive_mapper_save_state", POTMAP_ERROR_IO, [&] {
    const potmap_drive_mapper& h = checked(mapper);
    require(path, "path");
    h.mapper->save_state(path);
  });
}

potmap_status potmap_drive_mapper_load_state(potmap_drive_mapper* mapper, const char* path) {
  return guard("potmap_drive_mapper_load_state", POTMAP_ERROR_INPUT, [&] {
    potmap_drive_mapper& h = checked(mapper);
    require(path, "path");
    h.mapper->load_state(path);
  });
}

}  // extern "C"
