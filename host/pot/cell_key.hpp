#pragma once
// One hash key for a grid cell's integer coordinates (the hash grids of host/pot share it).

#include <cstdint>

namespace potmap::detail {

/// 21 bits an axis (+-1e6 cells; 262 km at 0.25 m cells); z = 0 in 2D.
inline std::uint64_t pack_cell(const std::int64_t c[3]) {
  const auto u = [](std::int64_t v) { return std::uint64_t(v + (1 << 20)) & 0x1FFFFF; };
  return u(c[0]) | (u(c[1]) << 21) | (u(c[2]) << 42);
}

}  // namespace potmap::detail
