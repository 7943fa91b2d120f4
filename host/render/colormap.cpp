// Colour maps as anchor tables of the published viridis and magma maps (van der Walt and Smith,
// 2015): their 10-colour and 5-colour samplings (t = k/9 and k/4), interpolated linearly in
// sRGB. That is an approximation of the 256-entry originals, close enough for occupancy
// pictures; the tests check that lightness still rises monotonically.
#include <algorithm>
#include <cctype>
#include <cmath>

#include "potmap/error.hpp"
#include "potmap/render/colormap.hpp"

namespace potmap {

namespace {

struct Anchor {
  double t;
  unsigned rgb;  // 0xRRGGBB
};

constexpr Anchor kViridis[] = {{0.0 / 9, 0x440154}, {1.0 / 9, 0x482878}, {2.0 / 9, 0x3E4A89},
                               {0.25, 0x3B528B},    {3.0 / 9, 0x31688E}, {4.0 / 9, 0x26828E},
                               {0.5, 0x21908C},     {5.0 / 9, 0x1F9E89}, {6.0 / 9, 0x35B779},
                               {0.75, 0x5DC863},    {7.0 / 9, 0x6DCD59}, {8.0 / 9, 0xB4DE2C},
                               {9.0 / 9, 0xFDE725}};

constexpr Anchor kMagma[] = {{0.0 / 9, 0x000004}, {1.0 / 9, 0x180F3E}, {2.0 / 9, 0x451077},
                             {0.25, 0x51127C},    {3.0 / 9, 0x721F81}, {4.0 / 9, 0x9F2F7F},
                             {0.5, 0xB63679},     {5.0 / 9, 0xCD4071}, {6.0 / 9, 0xF1605D},
                             {0.75, 0xFB8861},    {7.0 / 9, 0xFD9567}, {8.0 / 9, 0xFEC98D},
                             {9.0 / 9, 0xFCFDBF}};

template <std::size_t N>
Rgb lookup(const Anchor (&table)[N], double t) {
  t = std::clamp(t, 0.0, 1.0);
  std::size_t k = 1;
  while (k < N - 1 && table[k].t < t) ++k;
  const Anchor& a = table[k - 1];
  const Anchor& b = table[k];
  const double u = (t - a.t) / (b.t - a.t);
  auto channel = [u](unsigned ca, unsigned cb) {
    return static_cast<std::uint8_t>(std::lround(ca + u * (double(cb) - double(ca))));
  };
  return {channel(a.rgb >> 16 & 0xff, b.rgb >> 16 & 0xff),
          channel(a.rgb >> 8 & 0xff, b.rgb >> 8 & 0xff), channel(a.rgb & 0xff, b.rgb & 0xff)};
}

}  // namespace

Rgb colormap(Colormap map, double t) {
  if (std::isnan(t)) return {128, 128, 128};
  switch (map) {
    case Colormap::Magma:
      return lookup(kMagma, t);
    case Colormap::Viridis:
    default:
      return lookup(kViridis, t);
  }
}

Colormap parse_colormap(const std::string& name) {
  std::string n = name;
  std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) { return std::tolower(c); });
  if (n == "viridis") return Colormap::Viridis;
  if (n == "magma") return Colormap::Magma;
  throw ArgumentError("unknown colour map '" + name + "' (expected viridis or magma)");
}

}  // namespace potmap
