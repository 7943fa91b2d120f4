// POT's averaged map in a .potmap file with its anchors' sums, so that such files merge
// (include/potmap/mapping/map_files.hpp). The section after the map holds, little-endian,
//   u32 section layout (2)
//   the averaged map's options and running sums as pot/averaged_map_state.hpp writes them
#include <cmath>
#include <optional>
#include <string>

#include "io/container_cursor.hpp"
#include "io/map_io_native.hpp"
#include "pot/averaged_map_state.hpp"
#include "potmap/error.hpp"
#include "potmap/mapping/map_files.hpp"

namespace potmap {

void write_averaged_map(const AveragedMap& map, const std::string& path) {
  detail::check_potmap_name(path, "an averaged map's anchor sums");
  detail::write_map_native_with_section(map.map(), path, [&](detail::ContainerWriter& w) {
    w.u32(detail::kAveragedMapSection);
    detail::AveragedMapState::write(w, map);
  });
}

std::optional<AveragedMap> read_averaged_map_information(const std::string& path) {
  const detail::ContainerReader r(path, detail::native_map_layout());
  const std::size_t at = detail::map_section_of(r);
  if (at == 0) return std::nullopt;
  detail::ContainerCursor c(r, at);
  if (c.u32() != detail::kAveragedMapSection) return std::nullopt;
  // The options the state was saved with come first; the map is built with them, then read.
  detail::ContainerCursor peek = c;
  const std::uint32_t dim = peek.u32();
  AveragedMapOptions o;
  o.spacing = peek.f64();
  o.min_support = peek.f64();
  o.ridge = peek.f64();
  const double sweeps = peek.f64();
  if (!(sweeps >= 0 && sweeps <= 1e6))
    r.fail(c.at() + 28, "averaged map: sweeps " + std::to_string(sweeps));
  o.sweeps = static_cast<int>(sweeps);
  std::optional<AveragedMap> m;
  try {
    m.emplace(static_cast<int>(dim), o);
  } catch (const ArgumentError& e) {
    r.fail(c.at(), std::string("averaged map options: ") + e.what());
  }
  detail::AveragedMapState::read(c, *m);
  c.finish();
  return m;
}

}  // namespace potmap
