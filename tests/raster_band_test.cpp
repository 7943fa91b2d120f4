// Rasters of a 3D map's height band: the files hold the evaluator's band maximum, do not depend
// on the row bands they were streamed in, and the tiled GeoTIFF job holds the same values.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>

#include "io/geotiff_writer.hpp"
#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/height_band.hpp"
#include "potmap/map/raster.hpp"
#include "potmap/map/raster_tiles.hpp"
#include "test_support.hpp"

using namespace potmap;
namespace fs = std::filesystem;

namespace {

// The float32 values of a .npy file written by rasterize (row 0 the top).
std::vector<float> npy_values(const std::string& path) {
  const std::string s = test::file_bytes(path);
  const std::size_t header =
      10 + (static_cast<unsigned char>(s.at(8)) | static_cast<unsigned char>(s.at(9)) << 8);
  std::vector<float> v((s.size() - header) / 4);
  std::memcpy(v.data(), s.data() + header, v.size() * 4);  // x86: little-endian
  return v;
}

// Walls and posts of different heights over a floor: the band's maximum comes from different
// levels in different columns.
KernelMap scene_3d() {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> xy(-4, 4), z(-1, 2.5);
  KernelMap map;
  map.dim = 3;
  for (int k = 0; k < 300; ++k) {
    const double p[3] = {xy(rng), xy(rng), z(rng)};
    map.push_back(p, 4.0, k % 3 ? -2.0 : 5.0, 0.3);
  }
  return map;
}

RasterSpec band_window() {
  RasterSpec s;
  s.xmin = -4.2;
  s.xmax = 4.3;
  s.ymin = -4.1;
  s.ymax = 4.25;
  s.resolution = 0.05;  // 170 x 167 cells
  s.band_lo = -0.5;
  s.band_hi = 1.5;
  s.band_step = 0.1;
  return s;
}

}  // namespace

TEST(RasterBand, FilesHoldTheEvaluatorsBandMaximum) {
  const KernelMap map = scene_3d();
  const RasterSpec spec = band_window();
  const std::size_t W = spec.width(), H = spec.height();
  const std::string dir = test::temp_dir("raster-band");
  RasterOptions o;
  o.max_band_cells = W * 64;  // three row bands
  const RasterSummary s = rasterize(test::context(), map, spec, dir + "/band", o);
  EXPECT_EQ(s.bands, 3u);
  EXPECT_EQ(s.levels, 21u);
  EXPECT_NEAR(s.level_spacing, 0.1, 1e-12);
  EXPECT_EQ(s.files.size(), 4u);
  const std::vector<float> p = npy_values(dir + "/band_prob.npy");
  const std::vector<float> v = npy_values(dir + "/band_var.npy");
  ASSERT_EQ(p.size(), W * H);

  // The whole window at once through the evaluator: the same tiles, so the same bits.
  GridSpec g;
  g.dim = 3;
  g.resolution = spec.resolution;
  g.origin[0] = spec.xmin;
  g.origin[1] = spec.ymin;
  g.count[0] = W;
  g.count[1] = H;
  MapEvaluator ev(test::context(), map);
  std::vector<float> ep(W * H), evar(W * H);
  const std::vector<double> levels = height_band_levels(-0.5, 1.5, 0.1);
  ev.evaluate_band_max(g, levels, nullptr, evar.data(), ep.data());
  for (std::size_t r = 0; r < H; ++r)
    for (std::size_t c = 0; c < W; ++c) {
      ASSERT_EQ(p[r * W + c], ep[(H - 1 - r) * W + c]) << r << "," << c;
      ASSERT_EQ(v[r * W + c], evar[(H - 1 - r) * W + c]) << r << "," << c;
    }

  // One row band gives the same files, bit for bit.
  o.max_band_cells = std::size_t(1) << 22;
  const RasterSummary one = rasterize(test::context(), map, spec, dir + "/one", o);
  EXPECT_EQ(one.bands, 1u);
  for (const char* f : {"_prob.npy", "_var.npy", "_prob.png", "_var.png"})
    EXPECT_EQ(test::file_bytes(dir + "/band" + f), test::file_bytes(dir + "/one" + f)) << f;

  // The band is above every slice in it, and differs from the slice at its middle.
  RasterSpec slice = spec;
  slice.band_lo = slice.band_hi = NAN;
  slice.z = 0.5;
  rasterize(test::context(), map, slice, dir + "/slice", o);
  const std::vector<float> ps = npy_values(dir + "/slice_prob.npy");
  std::size_t above = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    ASSERT_GE(p[i], ps[i] - 1e-6f) << i;
    above += p[i] > ps[i] + 0.05f;
  }
  EXPECT_GT(above, p.size() / 10);
}

TEST(RasterBand, TiledGeoTiffHoldsTheSingleShotBand) {
  if (!geotiff_supported()) GTEST_SKIP() << "built without GDAL";
  const KernelMap map = scene_3d();
  const RasterSpec spec = band_window();
  const std::size_t W = spec.width(), H = spec.height();
  const std::string dir = test::temp_dir("raster-band-tiles");
  RasterOptions ro;
  ro.write_png = false;
  rasterize(test::context(), map, spec, dir + "/single", ro);
  const std::vector<float> p = npy_values(dir + "/single_prob.npy");
  const std::vector<float> v = npy_values(dir + "/single_var.npy");

  TiledRasterOptions to;
  to.tile_cells = 64;  // 3 x 3 tiles, the last row and column partial
  to.work_dir = dir + "/tiles";
  const TiledRasterSummary s = rasterize_tiled(test::context(), map, spec, dir + "/band.tif", to);
  EXPECT_EQ(s.tiles, 9u);
  EXPECT_EQ(s.levels, 21u);
  const detail::GeoTiffImage gp = detail::read_geotiff_band(dir + "/band.tif", 1);
  const detail::GeoTiffImage gv = detail::read_geotiff_band(dir + "/band.tif", 2);
  ASSERT_EQ(gp.width, W);
  ASSERT_EQ(gp.height, H);
  // Tiles cut the kernel lists elsewhere than the single pass: float rounding, and where two
  // levels tie to that rounding the other level's variance.
  double worst_p = 0;
  std::size_t other_level = 0;
  for (std::size_t i = 0; i < W * H; ++i) {
    worst_p = std::max(worst_p, double(std::fabs(gp.values[i] - p[i])));
    other_level += std::fabs(gv.values[i] - v[i]) > 1e-5 * (1 + std::fabs(v[i]));
  }
  EXPECT_LT(worst_p, 1e-5);
  EXPECT_LE(other_level, W * H / 1000);

  // A slice job's tiles are not this band's: the fingerprints differ.
  RasterSpec slice = spec;
  slice.band_lo = slice.band_hi = NAN;
  TiledRaster a(test::context(), map, spec, dir + "/a.tif", to);
  TiledRaster b(test::context(), map, slice, dir + "/b.tif", to);
  EXPECT_NE(a.fingerprint(), b.fingerprint());
}

TEST(RasterBand, BadBandsAreNamed) {
  const KernelMap map = scene_3d();
  RasterSpec spec = band_window();
  spec.band_hi = NAN;
  EXPECT_THROW(spec.validate(), ArgumentError);
  spec = band_window();
  spec.band_lo = 2.0;
  EXPECT_THROW(spec.validate(), ArgumentError);
  spec = band_window();
  spec.band_step = -0.1;
  EXPECT_THROW(spec.validate(), ArgumentError);
  // A band needs a 3D map; the error comes before any file is made.
  KernelMap flat;
  flat.dim = 2;
  const double p[2] = {0, 0};
  flat.push_back(p, 1.0, 1.0, 1.0);
  const std::string dir = test::temp_dir("raster-band-bad");
  try {
    rasterize(test::context(), flat, band_window(), dir + "/x");
    FAIL() << "a band on a 2D map was accepted";
  } catch (const ArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("3D map"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir + "/x_prob.png"));
  // The default step is the map's (kernels of gamma 4: 1 / sqrt(8) m).
  spec = band_window();
  spec.band_step = 0;
  const std::vector<double> z = raster_levels(spec, map);
  EXPECT_EQ(z.size(), std::size_t(std::ceil(2.0 / (1 / std::sqrt(8.0)))) + 1);
}
