#pragma once
// Versioned structs of the C API. Each begins with struct_size, the caller's sizeof: fields are
// only appended, so a caller compiled against an older potmap.h passes a shorter struct and the
// library reads or writes only the bytes it has, taking defaults for the rest.

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <string>

#include "capi_guard.hpp"
#include "potmap/data/scan.hpp"

namespace potmap::capi {

// Sizes of the first published versions: the smallest struct_size accepted. Frozen: when a
// field is appended, sizeof grows and these stay.
constexpr std::size_t kScanV1 = sizeof(potmap_scan);
constexpr std::size_t kDictionaryOptionsV1 = sizeof(potmap_dictionary_options);
constexpr std::size_t kMapperOptionsV1 = offsetof(potmap_mapper_options, persistent_refine);
constexpr std::size_t kScanStatsV1 = sizeof(potmap_scan_stats);
constexpr std::size_t kDriveMapperOptionsV1 = offsetof(potmap_drive_mapper_options, transfer_every);
constexpr std::size_t kBagOptionsV1 = sizeof(potmap_bag_options);
constexpr std::size_t kDriveVolumeOptionsV1 = sizeof(potmap_drive_volume_options);
constexpr std::size_t kDriveVolumeSummaryV1 = sizeof(potmap_drive_volume_summary);
constexpr std::size_t kKeyframeStatsV1 = offsetof(potmap_keyframe_stats, transfer_ms);

inline void check_struct_size(std::size_t size, std::size_t min, const char* what,
                              potmap_status too_small) {
  if (size < min)
    fail(too_small, std::string(what) + "->struct_size is " + std::to_string(size) + ", at least " +
                        std::to_string(min) +
                        " is needed (set it to sizeof the struct, or call its _init function)");
}

/// Writes `value` into the caller's struct, as many bytes as it has; struct_size is kept.
template <class T>
void write_struct(T* out, const T& value, std::size_t min, const char* what,
                  potmap_status too_small) {
  const std::size_t size = out->struct_size;
  check_struct_size(size, min, what, too_small);
  std::memcpy(out, &value, std::min(size, sizeof(T)));
  out->struct_size = size;
}

/// A struct's *_init function: `value` written into the caller's `size` bytes of *out, which
/// must hold at least the first version's `min`.
template <class T>
void init_struct(T* out, std::size_t size, const T& value, std::size_t min, const char* what) {
  require(out, what);
  check_struct_size(size, min, what, POTMAP_ERROR_INVALID_ARGUMENT);
  out->struct_size = size;
  write_struct(out, value, min, what, POTMAP_ERROR_INVALID_ARGUMENT);
}

/// The caller's struct read into a full one: defaults for the fields it does not have. A
/// struct_size larger than this library knows is refused: its extra fields would be ignored.
template <class T>
T read_struct(const T* in, const T& defaults, std::size_t min, const char* what) {
  check_struct_size(in->struct_size, min, what, POTMAP_ERROR_INVALID_ARGUMENT);
  if (in->struct_size > sizeof(T))
    fail(POTMAP_ERROR_INVALID_ARGUMENT,
         std::string(what) + "->struct_size is " + std::to_string(in->struct_size) +
             ": a newer potmap.h than this library (" + std::to_string(sizeof(T)) + " bytes)");
  T r = defaults;
  std::memcpy(&r, in, in->struct_size);
  r.struct_size = sizeof(T);
  return r;
}

/// A caller's scan (checked and copied) as the C++ Scan; `what` names it in messages.
Scan to_scan(const potmap_scan* scan, const std::string& what);

/// Converts n scan pointers, all of one dimension (DIMENSION_MISMATCH otherwise).
std::vector<Scan> to_scans(const potmap_scan* const* scans, std::size_t n);

}  // namespace potmap::capi
