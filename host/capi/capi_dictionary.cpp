// C API: a source map learned from scans (BHM), and dictionaries of atoms built, loaded, saved.
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "capi_handles.hpp"
#include "capi_structs.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/pot/dictionary_io.hpp"

namespace potmap::capi {
namespace {

potmap_dictionary_options default_dictionary_options() {
  const potmap::DictionaryOptions d;
  potmap_dictionary_options o{};
  o.struct_size = sizeof o;
  o.sectors = d.sectors.sectors;
  o.max_range = d.sectors.max_range;
  o.scale = d.sectors.scale;
  o.min_samples = d.sectors.min_samples;
  o.max_weight_variance = d.max_weight_variance;
  o.min_kernels = d.min_kernels;
  return o;
}

potmap::DictionaryOptions to_options(const potmap_dictionary_options* in) {
  const potmap_dictionary_options o =
      in ? read_struct(in, default_dictionary_options(), kDictionaryOptionsV1, "options")
         : default_dictionary_options();
  auto bad = [](const std::string& field, double v) {
    fail(POTMAP_ERROR_INVALID_ARGUMENT,
         "options->" + field + " is out of range: " + std::to_string(v));
  };
  if (o.sectors < 1) bad("sectors", o.sectors);
  if (!(o.max_range >= 0) || !std::isfinite(o.max_range)) bad("max_range", o.max_range);
  if (!(o.scale > 0) || !std::isfinite(o.scale)) bad("scale", o.scale);
  if (std::isnan(o.max_weight_variance) || o.max_weight_variance < 0)
    bad("max_weight_variance", o.max_weight_variance);
  potmap::DictionaryOptions d;
  d.sectors.sectors = o.sectors;
  d.sectors.max_range = o.max_range;
  d.sectors.scale = o.scale;
  d.sectors.min_samples = o.min_samples;
  d.max_weight_variance = o.max_weight_variance;
  d.min_kernels = o.min_kernels;
  return d;
}

potmap_dictionary* wrap(potmap::Dictionary&& d) {
  auto h = std::make_unique<potmap_dictionary>();
  h->dict = std::make_shared<const potmap::Dictionary>(std::move(d));
  return h.release();
}

}  // namespace
}  // namespace potmap::capi

using namespace potmap::capi;

extern "C" {

potmap_status potmap_map_learn_bhm(potmap_context* context, const potmap_scan* const* scans,
                                   size_t n, double spacing, double gamma, potmap_map** out) {
  return guard("potmap_map_learn_bhm", POTMAP_ERROR_INTERNAL, [&] {
    potmap_context& c = checked(context);
    require(scans, "scans");
    require(out, "out");
    if (n == 0) fail(POTMAP_ERROR_INVALID_ARGUMENT, "n is 0: no scans to learn from");
    if (spacing == 0) spacing = 1.0;
    if (!(spacing > 0) || !std::isfinite(spacing))
      fail(POTMAP_ERROR_INVALID_ARGUMENT,
           "spacing must be finite and > 0 metres, got " + std::to_string(spacing));
    if (gamma == 0) gamma = 8.0 / (spacing * spacing);
    if (!(gamma > 0) || !std::isfinite(gamma))
      fail(POTMAP_ERROR_INVALID_ARGUMENT,
           "gamma must be finite and > 0 (1/m^2), got " + std::to_string(gamma));
    const std::vector<potmap::Scan> s = to_scans(scans, n);
    potmap::LabelOptions lo;
    lo.holdout_fraction = 0;
    const potmap::LabelledSplit split = potmap::label_scans(s, lo);
    const potmap::LabelledPoints& train = split.train;
    if (train.empty()) fail(POTMAP_ERROR_INVALID_ARGUMENT, "the scans give no samples");
    const int dim = s[0].dim;
    double lo3[3] = {0, 0, 0}, hi3[3] = {0, 0, 0};
    for (int d = 0; d < dim; ++d) lo3[d] = hi3[d] = train.position[d];
    for (std::size_t i = 1; i < train.size(); ++i)
      for (int d = 0; d < dim; ++d) {
        lo3[d] = std::min(lo3[d], train.position[i * dim + d]);
        hi3[d] = std::max(hi3[d], train.position[i * dim + d]);
      }
    auto h = std::make_unique<potmap_map>();
    h->map = potmap::bhm_grid_prior(dim, lo3, hi3, spacing, gamma);
    potmap::bhm_update_sequential(c.ctx.get(), h->map, train);
    *out = h.release();
  });
}

potmap_status potmap_dictionary_options_init(potmap_dictionary_options* options,
                                             size_t struct_size) {
  return guard("potmap_dictionary_options_init", POTMAP_ERROR_INTERNAL, [&] {
    init_struct(options, struct_size, default_dictionary_options(), kDictionaryOptionsV1,
                "options");
  });
}

potmap_status potmap_dictionary_build(const potmap_scan* const* scans, size_t n,
                                      const potmap_map* map,
                                      const potmap_dictionary_options* options,
                                      potmap_dictionary** out) {
  return guard("potmap_dictionary_build", POTMAP_ERROR_INTERNAL, [&] {
    const potmap::KernelMap& m = checked(map).map;
    require(scans, "scans");
    require(out, "out");
    const potmap::DictionaryOptions o = to_options(options);
    const std::vector<potmap::Scan> s = to_scans(scans, n);
    if (!s.empty() && s[0].dim != m.dim)
      fail(POTMAP_ERROR_DIMENSION_MISMATCH, "the scans are " + std::to_string(s[0].dim) +
                                                "D, the map " + std::to_string(m.dim) + "D");
    potmap::Dictionary d;
    potmap::build_dictionary(s, m, o, d);
    if (d.empty())
      fail(POTMAP_ERROR_INVALID_ARGUMENT,
           "the scans and map gave no atom (no sector with enough samples and kernels)");
    *out = wrap(std::move(d));
  });
}

potmap_status potmap_dictionary_load(const char* path, potmap_dictionary** out) {
  return guard("potmap_dictionary_load", POTMAP_ERROR_INPUT, [&] {
    require(path, "path");
    require(out, "out");
    *out = wrap(potmap::read_dictionary(path));
  });
}

potmap_status potmap_dictionary_save(const potmap_dictionary* dictionary, const char* path) {
  return guard("potmap_dictionary_save", POTMAP_ERROR_IO, [&] {
    const potmap_dictionary& d = checked(dictionary);
    require(path, "path");
    potmap::write_dictionary(*d.dict, path);
  });
}

potmap_status potmap_dictionary_destroy(potmap_dictionary* dictionary) {
  return destroy(dictionary, kDictionaryTag, "potmap_dictionary_destroy");
}

potmap_status potmap_dictionary_info(const potmap_dictionary* dictionary, int* dim, size_t* atoms,
                                     size_t* kernels, double* scale, double* max_range,
                                     int* sectors) {
  return guard("potmap_dictionary_info", POTMAP_ERROR_INTERNAL, [&] {
    const potmap::Dictionary& d = *checked(dictionary).dict;
    if (dim) *dim = d.dim;
    if (atoms) *atoms = d.size();
    if (kernels) {
      std::size_t k = 0;
      for (const potmap::Atom& a : d.atoms) k += a.kernels.size();
      *kernels = k;
    }
    if (scale) *scale = d.scale;
    if (max_range) *max_range = d.max_range;
    if (sectors) *sectors = d.sectors;
  });
}

}  // extern "C"
