#pragma once
// What the C API's opaque handles hold. Each begins with a type tag that *_destroy clears, so a
// handle of the wrong type, or (best effort) one already destroyed, is refused.

#include <cstdint>
#include <memory>
#include <string>

#include "capi_guard.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/mapping/drive_mapper.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/kernel_map.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/potmap.h"
#include "potmap/runtime/context.hpp"

namespace potmap::capi {
constexpr std::uint32_t kContextTag = 0x43504d50;      // "PMPC"
constexpr std::uint32_t kMapTag = 0x4d504d50;          // "PMPM"
constexpr std::uint32_t kEvaluatorTag = 0x45504d50;    // "PMPE"
constexpr std::uint32_t kDatasetTag = 0x53504d50;      // "PMPS"
constexpr std::uint32_t kDictionaryTag = 0x44504d50;   // "PMPD"
constexpr std::uint32_t kMapperTag = 0x52504d50;       // "PMPR"
constexpr std::uint32_t kDriveMapperTag = 0x56504d50;  // "PMPV"
constexpr std::uint32_t kDeadTag = 0xdeadbeef;
}  // namespace potmap::capi

struct potmap_context {
  std::uint32_t tag = potmap::capi::kContextTag;
  // Shared with the evaluators made from it, so that handles may be destroyed in any order.
  std::shared_ptr<potmap::Context> ctx;
  potmap_device_info info{};  // its strings point into ctx->info()
};

struct potmap_map {
  std::uint32_t tag = potmap::capi::kMapTag;
  potmap::KernelMap map;
};

struct potmap_evaluator {
  std::uint32_t tag = potmap::capi::kEvaluatorTag;
  std::shared_ptr<potmap::Context> ctx;  // declared first: destroyed after the evaluator
  std::unique_ptr<potmap::MapEvaluator> eval;
  int dim = 2;
  double band_step = 0.1;  // the map's default height-band step (default_band_step)
};

struct potmap_dataset {
  std::uint32_t tag = potmap::capi::kDatasetTag;
  potmap::Dataset data;
};

struct potmap_dictionary {
  std::uint32_t tag = potmap::capi::kDictionaryTag;
  // Shared with the mappers made from it; never changed once built or loaded.
  std::shared_ptr<const potmap::Dictionary> dict;
};

struct potmap_mapper {
  std::uint32_t tag = potmap::capi::kMapperTag;
  std::shared_ptr<potmap::Context> ctx;  // declared first: destroyed after the mapper
  std::unique_ptr<potmap::Mapper> mapper;
};

struct potmap_drive_mapper {
  std::uint32_t tag = potmap::capi::kDriveMapperTag;
  std::shared_ptr<potmap::Context> ctx;  // may be null: the update on the caller's thread
  std::unique_ptr<potmap::DriveMapper> mapper;
};

namespace potmap::capi {

/// The handle, checked: null or of another type (or destroyed) fails.
template <class H>
H& checked(H* h, std::uint32_t tag, const char* what) {
  if (!h) fail(POTMAP_ERROR_NULL_ARGUMENT, std::string(what) + " is null");
  if (h->tag != tag)
    fail(POTMAP_ERROR_INVALID_HANDLE, std::string(what) +
                                          " is not a live handle of its type (wrong type, or "
                                          "already destroyed)");
  return *h;
}

inline potmap_context& checked(const potmap_context* h) {
  return checked(const_cast<potmap_context*>(h), kContextTag, "context");
}
inline potmap_map& checked(const potmap_map* h) {
  return checked(const_cast<potmap_map*>(h), kMapTag, "map");
}
inline potmap_evaluator& checked(potmap_evaluator* h) {
  return checked(h, kEvaluatorTag, "evaluator");
}
inline potmap_dataset& checked(const potmap_dataset* h) {
  return checked(const_cast<potmap_dataset*>(h), kDatasetTag, "dataset");
}
inline potmap_dictionary& checked(const potmap_dictionary* h) {
  return checked(const_cast<potmap_dictionary*>(h), kDictionaryTag, "dictionary");
}
inline potmap_mapper& checked(const potmap_mapper* h) {
  return checked(const_cast<potmap_mapper*>(h), kMapperTag, "mapper");
}
/// Whether `path` names a .potmap file (any case): where a joint BHM's information form goes.
inline bool is_potmap_file(const std::string& path) {
  const std::size_t dot = path.rfind('.');
  if (dot == std::string::npos || path.find('/', dot) != std::string::npos) return false;
  std::string ext = path.substr(dot);
  for (char& c : ext)
    if (c >= 'A' && c <= 'Z') c = static_cast<char>(c - 'A' + 'a');
  return ext == ".potmap";
}

inline potmap_drive_mapper& checked(const potmap_drive_mapper* h) {
  return checked(const_cast<potmap_drive_mapper*>(h), kDriveMapperTag, "drive mapper");
}

/// Clears the tag and frees the handle; null does nothing.
template <class H>
potmap_status destroy(H* h, std::uint32_t tag, const char* function) noexcept {
  return guard(function, POTMAP_ERROR_INTERNAL, [&] {
    if (!h) return;
    checked(h, tag, "handle");
    h->tag = kDeadTag;
    delete h;
  });
}

}  // namespace potmap::capi
