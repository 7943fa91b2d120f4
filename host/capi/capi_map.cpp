// C API: kernel maps in host memory (create from arrays, load, save, read back).
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "capi_handles.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/mapping/map_files.hpp"

namespace potmap::capi {
namespace {

void check_dim(int dim) {
  if (dim != 2 && dim != 3)
    fail(POTMAP_ERROR_INVALID_ARGUMENT, "dim must be 2 or 3, got " + std::to_string(dim));
}

}  // namespace
}  // namespace potmap::capi

using namespace potmap::capi;

extern "C" {

potmap_status potmap_map_create(int dim, size_t count, const double* positions, const double* gamma,
                                const double* w_mean, const double* w_var, potmap_map** out) {
  return guard("potmap_map_create", POTMAP_ERROR_INTERNAL, [&] {
    require(out, "out");
    check_dim(dim);
    if (count > 0) {
      require(positions, "positions");
      require(gamma, "gamma");
      require(w_mean, "w_mean");
      require(w_var, "w_var");
    }
    if (count > std::numeric_limits<std::size_t>::max() / (8 * 3))
      fail(POTMAP_ERROR_INVALID_ARGUMENT, "count " + std::to_string(count) + " is too large");
    auto h = std::make_unique<potmap_map>();
    potmap::KernelMap& m = h->map;
    m.dim = dim;
    if (count > 0) {
      m.position.assign(positions, positions + count * dim);
      m.gamma.assign(gamma, gamma + count);
      m.w_mean.assign(w_mean, w_mean + count);
      m.w_var.assign(w_var, w_var + count);
    }
    m.validate();
    *out = h.release();
  });
}

potmap_status potmap_map_load(const char* path, potmap_map** out) {
  return guard("potmap_map_load", POTMAP_ERROR_INPUT, [&] {
    require(path, "path");
    require(out, "out");
    auto h = std::make_unique<potmap_map>();
    h->map = potmap::read_map(path);
    *out = h.release();
  });
}

potmap_status potmap_map_save(const potmap_map* map, const char* path) {
  return guard("potmap_map_save", POTMAP_ERROR_IO, [&] {
    const potmap_map& m = checked(map);
    require(path, "path");
    potmap::write_map(m.map, path);
  });
}

potmap_status potmap_map_destroy(potmap_map* map) {
  return destroy(map, kMapTag, "potmap_map_destroy");
}

potmap_status potmap_merge_maps(const char* const* paths, size_t count, const char* out,
                                int allow_overlap) {
  return guard("potmap_merge_maps", POTMAP_ERROR_IO, [&] {
    require(paths, "paths");
    require(out, "out");
    std::vector<std::string> files;
    for (size_t i = 0; i < count; ++i) {
      require(paths[i], "paths[i]");
      files.emplace_back(paths[i]);
    }
    potmap::JointBhmMergeOptions o;
    o.allow_overlap = allow_overlap != 0;
    potmap::merge_map_files(files, out, o);
  });
}

potmap_status potmap_map_size(const potmap_map* map, int* dim, size_t* count) {
  return guard("potmap_map_size", POTMAP_ERROR_INTERNAL, [&] {
    const potmap_map& m = checked(map);
    require(dim, "dim");
    require(count, "count");
    *dim = m.map.dim;
    *count = m.map.size();
  });
}

potmap_status potmap_map_read(const potmap_map* map, double* positions, size_t positions_capacity,
                              double* gamma, double* w_mean, double* w_var, size_t capacity) {
  return guard("potmap_map_read", POTMAP_ERROR_INTERNAL, [&] {
    const potmap::KernelMap& m = checked(map).map;
    if (!positions && !gamma && !w_mean && !w_var)
      fail(POTMAP_ERROR_NULL_ARGUMENT, "every output array is null");
    const std::size_t n = m.size(), np = m.position.size();
    if (positions && positions_capacity < np)
      fail(POTMAP_ERROR_BUFFER_TOO_SMALL, "positions holds " + std::to_string(positions_capacity) +
                                              " doubles, the map needs " + std::to_string(np));
    if ((gamma || w_mean || w_var) && capacity < n)
      fail(POTMAP_ERROR_BUFFER_TOO_SMALL, "capacity is " + std::to_string(capacity) +
                                              " doubles, the map has " + std::to_string(n) +
                                              " kernels");
    if (positions) std::copy(m.position.begin(), m.position.end(), positions);
    if (gamma) std::copy(m.gamma.begin(), m.gamma.end(), gamma);
    if (w_mean) std::copy(m.w_mean.begin(), m.w_mean.end(), w_mean);
    if (w_var) std::copy(m.w_var.begin(), m.w_var.end(), w_var);
  });
}

potmap_status potmap_map_set_bias(potmap_map* map, int has_bias, double mean, double var) {
  return guard("potmap_map_set_bias", POTMAP_ERROR_INTERNAL, [&] {
    potmap::KernelMap& m = checked(map).map;
    if (has_bias) {
      if (!std::isfinite(mean))
        fail(POTMAP_ERROR_INVALID_ARGUMENT,
             "bias mean must be finite, got " + std::to_string(mean));
      if (!std::isfinite(var) || var < 0)
        fail(POTMAP_ERROR_INVALID_ARGUMENT,
             "bias variance must be finite and >= 0, got " + std::to_string(var));
    }
    m.has_bias = has_bias != 0;
    m.bias_mean = has_bias ? mean : 0.0;
    m.bias_var = has_bias ? var : 0.0;
  });
}

potmap_status potmap_map_bias(const potmap_map* map, int* has_bias, double* mean, double* var) {
  return guard("potmap_map_bias", POTMAP_ERROR_INTERNAL, [&] {
    const potmap::KernelMap& m = checked(map).map;
    if (has_bias) *has_bias = m.has_bias ? 1 : 0;
    if (mean) *mean = m.has_bias ? m.bias_mean : 0.0;
    if (var) *var = m.has_bias ? m.bias_var : 0.0;
  });
}

potmap_status potmap_map_set_cutoff(potmap_map* map, double tau) {
  return guard("potmap_map_set_cutoff", POTMAP_ERROR_INTERNAL, [&] {
    if (!(tau > 0))
      fail(POTMAP_ERROR_INVALID_ARGUMENT,
           "the cut-off exponent must be positive (INFINITY for none), got " + std::to_string(tau));
    checked(map).map.cutoff_tau = tau;
  });
}

potmap_status potmap_map_cutoff(const potmap_map* map, double* tau) {
  return guard("potmap_map_cutoff", POTMAP_ERROR_INTERNAL, [&] {
    const potmap::KernelMap& m = checked(map).map;
    if (tau) *tau = m.cutoff_tau;
  });
}

}  // extern "C"
