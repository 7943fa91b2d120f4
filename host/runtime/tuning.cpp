#include "potmap/runtime/tuning.hpp"

#include <cctype>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "potmap/error.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap {

namespace {

// One row per tunable field: its name as `routine.field` and where it lives in a Tuning. A
// size_t field is read through `big`, the others through `small`.
struct Field {
  const char* name;
  int* (*small)(Tuning&);
  std::size_t* (*big)(Tuning&);
};

template <class F>
Field small_field(const char* name, F f) {
  return {name, +f, nullptr};
}
template <class F>
Field big_field(const char* name, F f) {
  return {name, nullptr, +f};
}

const std::vector<Field>& fields() {
  static const std::vector<Field> table = {
      small_field("map_eval.vector_width", [](Tuning& t) { return &t.map_eval.vector_width; }),
      small_field("map_eval.work_group", [](Tuning& t) { return &t.map_eval.work_group; }),
      small_field("map_eval.cells_work_group",
                  [](Tuning& t) { return &t.map_eval.cells_work_group; }),
      small_field("map_eval.chunks_per_query",
                  [](Tuning& t) { return &t.map_eval.chunks_per_query; }),
      small_field("raster.rows_per_item", [](Tuning& t) { return &t.raster.rows_per_item; }),
      small_field("raster.tile", [](Tuning& t) { return &t.raster.tile; }),
      small_field("sinkhorn.work_group", [](Tuning& t) { return &t.sinkhorn.work_group; }),
      small_field("sinkhorn.groups_per_compute_unit",
                  [](Tuning& t) { return &t.sinkhorn.groups_per_compute_unit; }),
      big_field("sinkhorn.chunk_slots", [](Tuning& t) { return &t.sinkhorn.chunk_slots; }),
      small_field("learn.bhm_work_group", [](Tuning& t) { return &t.learn.bhm_work_group; }),
      small_field("learn.abhm_work_group", [](Tuning& t) { return &t.learn.abhm_work_group; }),
  };
  return table;
}

bool power_of_two(long long v) {
  return v > 0 && (v & (v - 1)) == 0;
}

void require(bool ok, const char* field, long long value, const char* rule) {
  if (!ok)
    throw ArgumentError(std::string("tuning ") + field + "=" + std::to_string(value) + ": " + rule);
}

}  // namespace

bool is_pocl_cpu(const DeviceInfo& device) {
  return device.is_cpu && device.platform == kPoclPlatform;
}

Tuning default_tuning(const DeviceInfo& device) {
  Tuning t;  // the CPU values
  if (!device.is_cpu) {
    t.map_eval.vector_width = 4;
    t.map_eval.work_group = 64;
    t.map_eval.cells_work_group = 128;
    t.sinkhorn.work_group = 64;
  } else if (is_pocl_cpu(device)) {
    // Measured end to end on PoCL's CPU device (docs/tuning.md); other CPU drivers keep the
    // generic CPU values above.
    t.sinkhorn.work_group = 1;
  }
  return t;
}

void validate_tuning(const Tuning& t) {
  const auto width = [](int v) { return v == 4 || v == 8 || v == 16; };
  require(width(t.map_eval.vector_width), "map_eval.vector_width", t.map_eval.vector_width,
          "must be 4, 8 or 16");
  require(power_of_two(t.map_eval.work_group), "map_eval.work_group", t.map_eval.work_group,
          "must be a power of two");
  require(power_of_two(t.map_eval.cells_work_group), "map_eval.cells_work_group",
          t.map_eval.cells_work_group, "must be a power of two");
  require(t.map_eval.chunks_per_query >= 1, "map_eval.chunks_per_query",
          t.map_eval.chunks_per_query, "must be at least 1");
  require(width(t.raster.rows_per_item), "raster.rows_per_item", t.raster.rows_per_item,
          "must be 4, 8 or 16");
  require(t.raster.tile == 16 || t.raster.tile == 32 || t.raster.tile == 64, "raster.tile",
          t.raster.tile, "must be 16, 32 or 64");
  require(power_of_two(t.sinkhorn.work_group), "sinkhorn.work_group", t.sinkhorn.work_group,
          "must be a power of two");
  require(t.sinkhorn.groups_per_compute_unit >= 1, "sinkhorn.groups_per_compute_unit",
          t.sinkhorn.groups_per_compute_unit, "must be at least 1");
  require(t.sinkhorn.chunk_slots >= 1, "sinkhorn.chunk_slots",
          static_cast<long long>(t.sinkhorn.chunk_slots), "must be at least 1");
  require(t.learn.bhm_work_group >= 1, "learn.bhm_work_group", t.learn.bhm_work_group,
          "must be at least 1");
  require(t.learn.abhm_work_group >= 1, "learn.abhm_work_group", t.learn.abhm_work_group,
          "must be at least 1");
}

Tuning parse_tuning(const std::string& spec, Tuning base) {
  std::string text = spec;
  for (char& c : text)
    if (c == ',') c = ' ';
  std::istringstream in(text);
  std::string pair;
  while (in >> pair) {
    const std::size_t eq = pair.find('=');
    if (eq == std::string::npos)
      throw ArgumentError("tuning '" + pair + "': expected routine.field=value");
    const std::string name = pair.substr(0, eq), value = pair.substr(eq + 1);
    const Field* field = nullptr;
    for (const Field& f : fields())
      if (name == f.name) field = &f;
    if (!field) {
      std::string known;
      for (const Field& f : fields()) known += std::string(known.empty() ? "" : ", ") + f.name;
      throw ArgumentError("tuning '" + pair + "': no field named '" + name + "' (fields: " + known +
                          ")");
    }
    char* end = nullptr;
    const long long v = value.empty() ? 0 : std::strtoll(value.c_str(), &end, 10);
    if (value.empty() || *end != '\0' || v < 0 ||
        (field->small && v > std::numeric_limits<int>::max()))
      throw ArgumentError("tuning '" + pair + "': value '" + value +
                          "' is not a whole number in range");
    if (field->small)
      *field->small(base) = static_cast<int>(v);
    else
      *field->big(base) = static_cast<std::size_t>(v);
  }
  validate_tuning(base);
  return base;
}

std::string to_string(const Tuning& t) {
  Tuning copy = t;
  std::string out;
  for (const Field& f : fields()) {
    const std::string v = f.small ? std::to_string(*f.small(copy)) : std::to_string(*f.big(copy));
    out += (out.empty() ? "" : ",") + std::string(f.name) + "=" + v;
  }
  return out;
}

}  // namespace potmap
