// C API: the mapping job, a recording into a folder (job/mapping_job.hpp).
#include <cmath>
#include <limits>
#include <string>

#include "capi_handles.hpp"
#include "capi_structs.hpp"
#include "potmap/job/mapping_job.hpp"

namespace potmap::capi {
namespace {

constexpr std::size_t kMappingJobOptionsV1 = offsetof(potmap_mapping_job_options, lookahead);
constexpr std::size_t kMappingJobResultV1 = offsetof(potmap_mapping_job_result, lookahead_auc);

potmap_mapping_job_options default_job_options() {
  const MappingJobOptions d;
  potmap_mapping_job_options o{};
  o.struct_size = sizeof o;
  o.range_cut = d.range_cut;
  o.first = d.first;
  o.max_scans = d.max_scans;
  o.seed = d.seed;
  o.half_life = d.half_life;
  o.picture_pixels = d.picture_pixels;
  o.band_low = d.band_low;
  o.band_high = d.band_high;
  o.voxel = d.voxel;
  o.checkpoint_every = d.checkpoint_every;
  o.checkpoint_seconds = d.checkpoint_seconds;
  o.export_every = d.export_every;
  o.resume = d.resume;
  o.lookahead = d.lookahead;
  return o;
}

std::string text(const char* s) {
  return s ? s : "";
}

void check_finite(double v, const char* field) {
  if (!std::isfinite(v))
    fail(POTMAP_ERROR_INVALID_ARGUMENT, std::string("options->") + field + " is not finite");
}

MappingJobOptions to_job_options(const potmap_mapping_job_options* in) {
  require(in, "options");
  const potmap_mapping_job_options o =
      read_struct(in, default_job_options(), kMappingJobOptionsV1, "options");
  if (!o.out || !*o.out) fail(POTMAP_ERROR_INVALID_ARGUMENT, "options->out: no output folder");
  for (auto [v, f] : {std::pair{o.range_cut, "range_cut"},
                      {o.half_life, "half_life"},
                      {o.band_low, "band_low"},
                      {o.band_high, "band_high"},
                      {o.voxel, "voxel"},
                      {o.checkpoint_seconds, "checkpoint_seconds"}})
    check_finite(v, f);
  if (!(o.voxel > 0))
    fail(POTMAP_ERROR_INVALID_ARGUMENT,
         "options->voxel must be positive, not " + std::to_string(o.voxel));
  if (!(o.band_high > o.band_low))
    fail(POTMAP_ERROR_INVALID_ARGUMENT, "options->band_high " + std::to_string(o.band_high) +
                                            " must be above band_low " +
                                            std::to_string(o.band_low));
  MappingJobOptions r;
  r.out = o.out;
  r.method = text(o.method);
  r.dictionary = text(o.dictionary);
  r.range_cut = o.range_cut;
  r.first = o.first;
  r.max_scans = o.max_scans;
  r.seed = o.seed;
  r.half_life = o.half_life;
  r.picture_pixels = o.picture_pixels;
  if (o.preset) r.preset = o.preset;
  r.band_low = o.band_low;
  r.band_high = o.band_high;
  r.voxel = o.voxel;
  r.checkpoint_every = o.checkpoint_every;
  r.checkpoint_seconds = o.checkpoint_seconds;
  r.export_every = o.export_every;
  r.resume = o.resume != 0;
  r.lookahead = o.lookahead != 0;
  return r;
}

// Thrown from the progress hook when the caller's callback asks to stop.
struct Cancelled {};

}  // namespace
}  // namespace potmap::capi

using namespace potmap::capi;

extern "C" {

potmap_status potmap_mapping_job_options_init(potmap_mapping_job_options* options,
                                              size_t struct_size) {
  return guard("potmap_mapping_job_options_init", POTMAP_ERROR_INTERNAL, [&] {
    init_struct(options, struct_size, default_job_options(), kMappingJobOptionsV1, "options");
  });
}

potmap_status potmap_map_recording(potmap_context* context, const char* path,
                                   const potmap_mapping_job_options* options,
                                   potmap_job_note_fn note, potmap_job_progress_fn progress,
                                   void* user, potmap_mapping_job_result* result) {
  return guard("potmap_map_recording", POTMAP_ERROR_IO, [&] {
    potmap_context& c = checked(context);
    require(path, "path");
    if (result)
      check_struct_size(result->struct_size, kMappingJobResultV1, "result",
                        POTMAP_ERROR_INVALID_ARGUMENT);
    const potmap::MappingJobOptions o = to_job_options(options);
    potmap::MappingJobHooks hooks;
    if (note) hooks.note = [note, user](const std::string& line) { note(line.c_str(), user); };
    if (progress)
      hooks.progress = [progress, user](const potmap::JobProgress& p) {
        const potmap_job_progress cp{p.stage.c_str(), p.unit.c_str(), p.done,
                                     p.total,         p.elapsed_s,    p.detail.c_str()};
        if (progress(&cp, user) != 0) throw Cancelled{};
      };
    potmap::MappingJobResult r;
    try {
      r = potmap::run_mapping_job(*c.ctx, path, o, hooks);
    } catch (const Cancelled&) {
      fail(POTMAP_ERROR_CANCELLED,
           std::string("stopped by the progress callback; ") + o.out + " holds only whole files");
    }
    if (!result) return;
    potmap_mapping_job_result s{};
    s.struct_size = sizeof s;
    s.drive = r.drive ? 1 : 0;
    s.files = r.files.size();
    s.acc = r.scores.acc;
    s.auc = r.scores.auc;
    s.nll = r.scores.nll;
    s.samples = r.scores.n;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    s.lookahead_auc = r.lookahead.n ? r.lookahead.auc : nan;
    s.lookahead_nll = r.lookahead.n ? r.lookahead.nll : nan;
    s.lookahead_samples = r.lookahead.n;
    s.beyond_auc = r.lookahead_beyond.n ? r.lookahead_beyond.auc : nan;
    s.beyond_nll = r.lookahead_beyond.n ? r.lookahead_beyond.nll : nan;
    s.beyond_samples = r.lookahead_beyond.n;
    write_struct(result, s, kMappingJobResultV1, "result", POTMAP_ERROR_INVALID_ARGUMENT);
  });
}

}  // extern "C"
