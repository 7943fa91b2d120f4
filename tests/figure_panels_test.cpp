// The experiments' pictures: never-observed places grey apart from free space, a 3D map's
// height band seen from above, and comparison figures with titled panels and a legend.
#include "potmap/experiments/figure_panels.hpp"

#include <gtest/gtest.h>
#include <png.h>

#include <algorithm>
#include <cmath>

#include "potmap/error.hpp"
#include "test_support.hpp"

using namespace potmap;
using namespace potmap::experiment;

namespace {

// P(occupied) x / 10 in 2D (z / 2 in 3D), observed where x > 0.
FittedMap ramp_map(int dim) {
  FittedMap f;
  f.query = [dim](const double* p, std::size_t n, double* prob, double*) {
    for (std::size_t i = 0; i < n; ++i)
      prob[i] = std::clamp(dim == 3 ? p[i * 3 + 2] / 2 : p[i * 2] / 10, 0.0, 1.0);
  };
  f.known = [dim](const double* p, std::size_t n, std::uint8_t* known) {
    for (std::size_t i = 0; i < n; ++i) known[i] = p[i * std::size_t(dim)] > 0;
  };
  return f;
}

Rgb pixel(const Picture& pic, std::size_t x, std::size_t y) {
  const std::uint8_t* p = &pic.rgb[(y * pic.width + x) * 3];
  return {p[0], p[1], p[2]};
}

bool same(Rgb a, Rgb b) {
  return a.r == b.r && a.g == b.g && a.b == b.b;
}

}  // namespace

TEST(FigurePanels, UnobservedPlacesAreGreyAndTheRestViridis) {
  const double lo[3] = {-10, 0, 0}, hi[3] = {10, 5, 0};
  const Picture pic = probability_picture(ramp_map(2), 2, lo, hi, 40);
  ASSERT_EQ(pic.width, 40u);
  ASSERT_EQ(pic.height, 10u);
  EXPECT_DOUBLE_EQ(pic.metres_per_pixel, 0.5);
  for (std::size_t x = 0; x < pic.width; ++x) {
    const double cx = lo[0] + (double(x) + 0.5) * 0.5;
    const Rgb want = cx > 0 ? colormap(Colormap::Viridis, cx / 10) : kUnknownGrey;
    EXPECT_TRUE(same(pixel(pic, x, 3), want)) << "column " << x;
  }
}

TEST(FigurePanels, A3dMapShowsTheLargestProbabilityOfItsBand) {
  const double lo[3] = {1, 0, -5}, hi[3] = {3, 2, 5};
  PictureView band;
  band.max_pixels = 4;
  band.band_lo = 0;
  band.band_hi = 1;
  const Picture top = probability_picture(ramp_map(3), 3, lo, hi, band);
  // The band's top (z 1) reads 0.5; the middle slice (z 0) would read 0.
  EXPECT_TRUE(same(pixel(top, 1, 1), colormap(Colormap::Viridis, 0.5)));
  const Picture mid = probability_picture(ramp_map(3), 3, lo, hi, 4);
  EXPECT_TRUE(same(pixel(mid, 1, 1), colormap(Colormap::Viridis, 0.0)));
  band.band_step = 0;
  EXPECT_THROW(probability_picture(ramp_map(3), 3, lo, hi, band), ArgumentError);
}

TEST(FigurePanels, ComparisonHasTitlesAndALegendBelowThePanels) {
  const double lo[3] = {-10, 0, 0}, hi[3] = {10, 20, 0};
  const Picture a = probability_picture(ramp_map(2), 2, lo, hi, 300);
  ASSERT_EQ(a.height, 300u);
  const std::string dir = test::temp_dir("figure_panels");
  const std::string path = dir + "/compare.png";
  write_comparison({&a, &a}, {"OGM 0.2 M", "BHM"}, path);
  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  ASSERT_TRUE(png_image_begin_read_from_file(&img, path.c_str())) << img.message;
  EXPECT_EQ(img.width, 2 * 300 + kComparisonGap);
  EXPECT_EQ(img.height, kComparisonTitleRows + a.height + kComparisonLegendRows);
  png_image_free(&img);
  EXPECT_THROW(write_comparison({&a}, {}, path), ArgumentError);
  EXPECT_THROW(write_comparison({}, {}, path), ArgumentError);
}
