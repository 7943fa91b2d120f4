// Tiled raster jobs: tiles equal the evaluator's grid, the GeoTIFF holds the tiles exactly and
// is georeferenced by the window, a stopped job resumes to the same file, corrupt or foreign
// tiles are recomputed.
#include "potmap/map/raster_tiles.hpp"

#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include <tiffio.h>

#include "io/geotiff_writer.hpp"
#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/synthetic.hpp"
#include "potmap/version.h"
#include "runtime/hash.hpp"
#include "test_support.hpp"

using namespace potmap;
namespace fs = std::filesystem;

namespace {

struct TilesFixture {
  SyntheticScene scene = make_synthetic_scene(3, 0.5, 10);
  RasterSpec spec;
  TilesFixture() {
    spec.xmin = scene.bounds[0];
    spec.xmax = scene.bounds[1];
    spec.ymin = scene.bounds[2];
    spec.ymax = scene.bounds[3];
    spec.resolution = (spec.xmax - spec.xmin) / 300.0;  // 300 cells across: 5 columns of 64
  }
  TiledRasterOptions options(const std::string& dir) const {
    TiledRasterOptions o;
    o.tile_cells = 64;
    o.work_dir = dir + "/tiles";
    return o;
  }
};

}  // namespace

TEST(RasterTiles, TilesAreTheEvaluatorsGridAndTheGeoTiffHoldsThem) {
  if (!geotiff_supported()) GTEST_SKIP() << "built without GDAL";
  TilesFixture f;
  const std::string dir = test::temp_dir("raster-tiles-grid");
  const std::string out = dir + "/map.tif";
  TiledRasterOptions o = f.options(dir);
  o.remove_tiles = false;
  const TiledRasterSummary s = rasterize_tiled(test::context(), f.scene.map, f.spec, out, o);
  const std::size_t tiles = ((f.spec.width() + 63) / 64) * ((f.spec.height() + 63) / 64);
  EXPECT_GE(tiles, 16u);
  EXPECT_EQ(s.tiles, tiles);
  EXPECT_EQ(s.computed, tiles);
  EXPECT_EQ(s.reused, 0u);
  ASSERT_TRUE(fs::exists(out));
  ASSERT_TRUE(fs::exists(s.manifest));

  // The whole window through the evaluator at once (grid rows bottom-up).
  const std::size_t W = f.spec.width(), H = f.spec.height();
  GridSpec g;
  g.dim = 2;
  g.resolution = f.spec.resolution;
  g.origin[0] = f.spec.xmin;
  g.origin[1] = f.spec.ymin;
  g.origin[2] = -0.5 * f.spec.resolution;
  g.count[0] = W;
  g.count[1] = H;
  g.count[2] = 1;
  MapEvaluator ev(test::context(), f.scene.map);
  const MapValues whole = ev.evaluate_grid(g);

  const detail::GeoTiffImage prob = detail::read_geotiff_band(out, 1);
  const detail::GeoTiffImage var = detail::read_geotiff_band(out, 2);
  ASSERT_EQ(prob.width, W);
  ASSERT_EQ(prob.height, H);
  EXPECT_EQ(prob.bands, 2u);
  EXPECT_EQ(prob.block_x, 64u);
  EXPECT_EQ(prob.block_y, 64u);
  EXPECT_GE(prob.overviews, 1u);
  // The first overview: each cell the mean of the (up to) 2 x 2 image cells it covers.
  ASSERT_EQ(prob.overview_width, (W + 1) / 2);
  ASSERT_EQ(prob.overview_height, (H + 1) / 2);
  for (std::size_t r = 0; r < prob.overview_height; ++r)
    for (std::size_t c = 0; c < prob.overview_width; ++c) {
      double sum = 0;
      int n = 0;
      for (std::size_t y = 2 * r; y < std::min(2 * r + 2, H); ++y)
        for (std::size_t x = 2 * c; x < std::min(2 * c + 2, W); ++x)
          if (!std::isnan(prob.values[y * W + x])) {
            sum += prob.values[y * W + x];
            ++n;
          }
      ASSERT_TRUE(n > 0);
      ASSERT_NEAR(prob.overview_values[r * prob.overview_width + c], sum / n, 1e-6)
          << "overview cell " << r << ", " << c;
    }
  EXPECT_DOUBLE_EQ(prob.geotransform[0], f.spec.xmin);
  EXPECT_DOUBLE_EQ(prob.geotransform[1], f.spec.resolution);
  EXPECT_DOUBLE_EQ(prob.geotransform[3], f.spec.ymin + double(H) * f.spec.resolution);
  EXPECT_DOUBLE_EQ(prob.geotransform[5], -f.spec.resolution);
  EXPECT_NE(prob.crs_wkt.find("potmap map frame"), std::string::npos) << prob.crs_wkt;

  // Image row r is grid row H - 1 - r. Tiles and the one-pass grid cut the kernel lists on
  // different tiles, so they agree to float rounding, not bit for bit.
  double worst_p = 0, worst_v = 0;
  for (std::size_t r = 0; r < H; ++r)
    for (std::size_t c = 0; c < W; ++c) {
      const std::size_t gi = (H - 1 - r) * W + c, ii = r * W + c;
      worst_p = std::max(worst_p, double(std::fabs(prob.values[ii] - whole.prob[gi])));
      worst_v = std::max(worst_v, double(std::fabs(var.values[ii] - whole.var[gi])) /
                                      (1.0 + std::fabs(whole.var[gi])));
    }
  EXPECT_LT(worst_p, 1e-5);
  EXPECT_LT(worst_v, 1e-5);

  // And the GeoTIFF holds each stored tile exactly.
  TiledRaster job(test::context(), f.scene.map, f.spec, out + ".again.tif", o);
  std::vector<float> tp, tv;
  for (const RasterTile& t : job.tiles()) {
    ASSERT_TRUE(job.complete(t)) << t.row << "," << t.col;
    job.load(t, tp, tv);
    for (std::size_t r = 0; r < t.height; ++r)
      for (std::size_t c = 0; c < t.width; ++c) {
        const std::size_t ii = (t.y0 + r) * W + t.x0 + c;
        ASSERT_EQ(tp[r * t.width + c], prob.values[ii]);
        ASSERT_EQ(tv[r * t.width + c], var.values[ii]);
      }
  }
}

namespace {

// The raw (compressed) bytes of every full-resolution block of a GeoTIFF, through libtiff.
std::vector<std::string> raw_blocks(const std::string& path) {
  std::unique_ptr<TIFF, void (*)(TIFF*)> t(TIFFOpen(path.c_str(), "r"), TIFFClose);
  EXPECT_TRUE(t) << path;
  std::vector<std::string> out;
  if (!t) return out;
  for (ttile_t i = 0; i < TIFFNumberOfTiles(t.get()); ++i) {
    std::string b(std::size_t(TIFFGetStrileByteCount(t.get(), i)), '\0');
    TIFFReadRawTile(t.get(), i, b.data(), tmsize_t(b.size()));
    out.push_back(b);
  }
  return out;
}

// Every directory of a GeoTIFF as libtiff reads it: the fields that describe its image (all
// but where its blocks are and their compressed sizes), then each block decoded.
std::vector<std::string> decoded_directories(const std::string& path) {
  std::unique_ptr<TIFF, void (*)(TIFF*)> t(TIFFOpen(path.c_str(), "r"), TIFFClose);
  EXPECT_TRUE(t) << path;
  std::vector<std::string> out;
  if (!t) return out;
  do {
    std::string d;
    for (ttag_t tag :
         {TIFFTAG_SUBFILETYPE, TIFFTAG_IMAGEWIDTH, TIFFTAG_IMAGELENGTH, TIFFTAG_COMPRESSION,
          TIFFTAG_PHOTOMETRIC, TIFFTAG_SAMPLESPERPIXEL, TIFFTAG_PLANARCONFIG, TIFFTAG_PREDICTOR,
          TIFFTAG_TILEWIDTH, TIFFTAG_TILELENGTH, TIFFTAG_BITSPERSAMPLE, TIFFTAG_SAMPLEFORMAT}) {
      std::uint32_t v = 0;
      if (tag == TIFFTAG_SUBFILETYPE || tag == TIFFTAG_IMAGEWIDTH || tag == TIFFTAG_IMAGELENGTH ||
          tag == TIFFTAG_TILEWIDTH || tag == TIFFTAG_TILELENGTH) {
        TIFFGetField(t.get(), tag, &v);
      } else {
        std::uint16_t u = 0;
        TIFFGetField(t.get(), tag, &u);
        v = u;
      }
      d += std::to_string(tag) + "=" + std::to_string(v) + ";";
    }
    std::string block(std::size_t(TIFFTileSize(t.get())), '\0');
    for (ttile_t i = 0; i < TIFFNumberOfTiles(t.get()); ++i) {
      EXPECT_EQ(TIFFReadEncodedTile(t.get(), i, block.data(), tmsize_t(block.size())),
                tmsize_t(block.size()))
          << path << " block " << i;
      d += block;
    }
    out.push_back(std::move(d));
  } while (TIFFReadDirectory(t.get()));
  return out;
}

// The compressed block a tile file holds: its last bytes before the CRC-32.
std::string tile_block(const std::string& tile_file, std::size_t bytes) {
  const std::string f = potmap::test::file_bytes(tile_file);
  return f.substr(f.size() - 4 - bytes, bytes);
}

}  // namespace

// Each tile is compressed once, when it is computed: the GeoTIFF's full-resolution blocks are
// the tile files' bytes, copied. And the file is the one GDAL's COG driver writes from the same
// values (write_cog: staging, then GDAL's copy, compressing every block again), byte for byte.
// ZSTD's fast levels (below 1) are libzstd's and libtiff's but not GDAL's, whose COG driver
// writes level 1 for them: there the file has the directories of GDAL's level-1 file and the
// same values in every block, and only the compressed bytes differ.
TEST(RasterTiles, BlocksAreCompressedOnceAndTheFileIsGdalsCog) {
  if (!geotiff_supported()) GTEST_SKIP() << "built without GDAL";
  TilesFixture f;
  const std::string dir = test::temp_dir("raster-tiles-once");
  // Each codec at its default level, and levels other than the default (ZSTD's fast and
  // ordinary ones, DEFLATE's strongest).
  const std::vector<std::pair<std::string, int>> codecs = {
      {"ZSTD", 0},    {"ZSTD", 1}, {"ZSTD", -7}, {"DEFLATE", 0},
      {"DEFLATE", 9}, {"LZW", 0},  {"NONE", 0}};
  for (const auto& [codec, level] : codecs) {
    const std::string name = codec + std::to_string(level);
    TiledRasterOptions o = f.options(dir + "/" + name);
    o.remove_tiles = false;
    o.compression = codec;
    o.compression_level = level;
    const std::string out = dir + "/" + name + ".tif";
    rasterize_tiled(test::context(), f.scene.map, f.spec, out, o);
    TiledRaster job(test::context(), f.scene.map, f.spec, out, o);
    const std::vector<std::string> blocks = raw_blocks(out);
    ASSERT_EQ(blocks.size(), job.tiles().size()) << name;
    for (const RasterTile& t : job.tiles()) {
      const std::string file =
          o.work_dir + "/tile_" + std::to_string(t.row) + "_" + std::to_string(t.col) + ".bin";
      ASSERT_TRUE(blocks[t.index] == tile_block(file, blocks[t.index].size()))
          << name << " tile " << t.row << "," << t.col;
    }

    // GDAL's COG driver from the same values and fields.
    detail::GeoTiffSpec g;
    g.width = job.width();
    g.height = job.height();
    g.block = o.tile_cells;
    g.left = f.spec.xmin;
    g.top = f.spec.ymin + double(job.height()) * f.spec.resolution;
    g.pixel = f.spec.resolution;
    g.compression = codec;
    g.level = level;
    g.band_names = {"probability", "variance"};
    g.metadata = {{"POTMAP_VERSION", POTMAP_VERSION_STRING},
                  {"POTMAP_JOB", detail::hex64(job.fingerprint())},
                  {"POTMAP_Z", "0"}};
    std::vector<float> p, v;
    detail::write_cog(
        dir + "/gdal.tif", g,
        [&](std::size_t x0, std::size_t y0, std::size_t w, std::size_t h, std::vector<float*>& b) {
          job.load(job.tiles()[(y0 / g.block) * ((g.width + 63) / 64) + x0 / g.block], p, v);
          ASSERT_EQ(p.size(), w * h);
          std::copy(p.begin(), p.end(), b[0]);
          std::copy(v.begin(), v.end(), b[1]);
        });
    if (codec == "NONE") {  // GDAL 3.6 lays an uncompressed COG out otherwise
      EXPECT_EQ(detail::read_geotiff_band(dir + "/gdal.tif", 2).values.size(),
                detail::read_geotiff_band(out, 2).values.size());
      continue;
    }
    if (codec == "ZSTD" && detail::default_level(codec, level) < 1) {
      const std::vector<std::string> ours = decoded_directories(out);
      EXPECT_EQ(ours.size(), detail::read_geotiff_band(out, 1).overviews + 1) << name;
      EXPECT_TRUE(ours == decoded_directories(dir + "/gdal.tif")) << name;
      EXPECT_FALSE(raw_blocks(out) == raw_blocks(dir + "/gdal.tif")) << name;
      continue;
    }
    // (EXPECT_TRUE: a failure would print both files.)
    EXPECT_TRUE(potmap::test::file_bytes(out) == potmap::test::file_bytes(dir + "/gdal.tif"))
        << name;
  }
}

// The overviews computed in memory (up to GeoTiffSpec::overview_memory: levels with even
// sources halved here, the rest by GDAL) and in a staging file (past it: all by GDAL) make the
// same file, and it is the file GDAL's COG driver writes from the values.
TEST(RasterTiles, OverviewsInMemoryEqualOverviewsStagedInAFile) {
  if (!geotiff_supported()) GTEST_SKIP() << "built without GDAL";
  const std::string dir = test::temp_dir("raster-overviews-memory");
  detail::GeoTiffSpec g;
  // Levels 336 x 211, 168 x 106, 84 x 53 (even sides: halved), 42 x 27 (from an odd side:
  // GDAL weighs the cells past it).
  g.width = 336;
  g.height = 211;
  g.block = 64;
  g.level = 1;  // a level GDAL's COG driver writes too
  g.band_names = {"probability", "variance"};
  std::vector<float> a(g.width * g.height), b(a.size());
  for (std::size_t y = 0; y < g.height; ++y)
    for (std::size_t x = 0; x < g.width; ++x) {
      const bool unknown = x > 200 && x < 260 && y > 30 && y < 120;
      a[y * g.width + x] = unknown ? std::nanf("") : float(0.5 + 0.5 * std::sin(0.05 * x * y));
      b[y * g.width + x] = unknown ? std::nanf("") : float(1e-3 * (x + 1) / (y + 1));
    }
  const std::size_t bx = (g.width + g.block - 1) / g.block, by = (g.height + g.block - 1) / g.block;
  const std::string blocks_file = dir + "/blocks.bin";
  std::vector<std::vector<float>> parts;  // each block's bands, one after the other
  std::vector<detail::EncodedBlock> where;
  std::string blob;
  for (std::size_t r = 0; r < by; ++r)
    for (std::size_t c = 0; c < bx; ++c) {
      const std::size_t x0 = c * g.block, y0 = r * g.block;
      const std::size_t w = std::min(g.block, g.width - x0), h = std::min(g.block, g.height - y0);
      std::vector<float> part(2 * w * h);
      for (std::size_t y = 0; y < h; ++y)
        for (std::size_t x = 0; x < w; ++x) {
          part[y * w + x] = a[(y0 + y) * g.width + x0 + x];
          part[w * h + y * w + x] = b[(y0 + y) * g.width + x0 + x];
        }
      const std::string bytes =
          detail::encode_block(blocks_file, g, {part.data(), part.data() + w * h}, w, h);
      where.push_back({blocks_file, blob.size(), bytes.size()});
      blob += bytes;
      parts.push_back(std::move(part));
    }
  std::ofstream(blocks_file, std::ios::binary) << blob;
  const detail::EncodedBlockSource source = [&](std::size_t r, std::size_t c,
                                                const std::vector<float*>& halves) {
    const std::size_t x0 = c * g.block, y0 = r * g.block;
    const std::size_t w = std::min(g.block, g.width - x0), h = std::min(g.block, g.height - y0);
    for (std::size_t k = 0; k < halves.size(); ++k)
      detail::average_halves(parts[r * bx + c].data() + k * w * h, w, h, halves[k]);
    return where[r * bx + c];
  };
  detail::write_cog_encoded(dir + "/memory.tif", g, source);
  g.overview_memory = 0;
  detail::write_cog_encoded(dir + "/file.tif", g, source);
  detail::write_cog(dir + "/gdal.tif", g,
                    [&](std::size_t x0, std::size_t y0, std::size_t w, std::size_t h,
                        std::vector<float*>& bands) {
                      for (std::size_t y = 0; y < h; ++y)
                        for (std::size_t x = 0; x < w; ++x) {
                          bands[0][y * w + x] = a[(y0 + y) * g.width + x0 + x];
                          bands[1][y * w + x] = b[(y0 + y) * g.width + x0 + x];
                        }
                    });
  EXPECT_EQ(detail::read_geotiff_band(dir + "/memory.tif", 1).overviews, 3u);
  EXPECT_TRUE(test::file_bytes(dir + "/memory.tif") == test::file_bytes(dir + "/file.tif"));
  EXPECT_TRUE(test::file_bytes(dir + "/memory.tif") == test::file_bytes(dir + "/gdal.tif"));
  std::set<std::string> left;  // no staging or partial file left behind
  for (const auto& e : fs::directory_iterator(dir)) left.insert(e.path().filename().string());
  EXPECT_EQ(left, (std::set<std::string>{"blocks.bin", "file.tif", "gdal.tif", "memory.tif"}));
}

TEST(RasterTiles, AStoppedJobResumesToTheSameFile) {
  if (!geotiff_supported()) GTEST_SKIP() << "built without GDAL";
  TilesFixture f;
  const std::string dir = test::temp_dir("raster-tiles-resume");
  const TiledRasterSummary whole = rasterize_tiled(test::context(), f.scene.map, f.spec,
                                                   dir + "/whole.tif", f.options(dir + "/a"));
  EXPECT_FALSE(fs::exists(dir + "/a/tiles")) << "tiles removed once the GeoTIFF is in place";

  // Stop after about half the tiles, as a kill would.
  const std::string out = dir + "/resumed.tif";
  const TiledRasterOptions o = f.options(dir + "/b");
  struct Stop {};
  EXPECT_THROW(rasterize_tiled(test::context(), f.scene.map, f.spec, out, o,
                               [](double fraction) {
                                 if (fraction > 0.45) throw Stop{};
                               }),
               Stop);
  EXPECT_FALSE(fs::exists(out));
  std::size_t left = 0;
  for (const auto& e : fs::directory_iterator(o.work_dir)) left += e.path().extension() == ".bin";
  EXPECT_GT(left, 5u);
  EXPECT_LT(left, 20u);

  const TiledRasterSummary s = rasterize_tiled(test::context(), f.scene.map, f.spec, out, o);
  EXPECT_EQ(s.reused, left);
  EXPECT_EQ(s.computed, whole.tiles - left);
  EXPECT_EQ(potmap::test::file_bytes(out), potmap::test::file_bytes(dir + "/whole.tif"));
}

// The job that stores the tiles assembles from its own record of them (checksums, first
// overview level); a job that finds them on disk reads the files. Both write the same bytes.
TEST(RasterTiles, AssemblyFromTheRecordEqualsAssemblyFromTheFiles) {
  if (!geotiff_supported()) GTEST_SKIP() << "built without GDAL";
  TilesFixture f;
  const std::string dir = test::temp_dir("raster-tiles-record");
  TiledRasterOptions o = f.options(dir);
  o.remove_tiles = false;
  const TiledRasterSummary s =
      rasterize_tiled(test::context(), f.scene.map, f.spec, dir + "/stored.tif", o);
  EXPECT_EQ(s.computed, s.tiles);
  EXPECT_GT(s.evaluate_seconds, 0.0);
  EXPECT_GT(s.store_seconds, 0.0);
  EXPECT_GT(s.assemble_seconds, 0.0);
  EXPECT_LE(s.evaluate_seconds + s.store_wait_seconds + s.assemble_seconds, s.seconds);

  TiledRaster found(test::context(), f.scene.map, f.spec, dir + "/found.tif", o);
  found.assemble();
  EXPECT_TRUE(test::file_bytes(dir + "/stored.tif") == test::file_bytes(dir + "/found.tif"));
  std::string a = test::file_bytes(dir + "/stored.tif.manifest.json");
  std::string b = test::file_bytes(dir + "/found.tif.manifest.json");
  a.replace(a.find("stored.tif"), 10, "found.tif");
  EXPECT_EQ(a, b) << "the tiles' checksums";
}

TEST(RasterTiles, CorruptAndForeignTilesAreRecomputed) {
  if (!geotiff_supported()) GTEST_SKIP() << "built without GDAL";
  TilesFixture f;
  const std::string dir = test::temp_dir("raster-tiles-corrupt");
  TiledRasterOptions o = f.options(dir);
  o.remove_tiles = false;
  const std::string out = dir + "/map.tif";
  rasterize_tiled(test::context(), f.scene.map, f.spec, out, o);
  const std::string first = potmap::test::file_bytes(out);

  TiledRaster job(test::context(), f.scene.map, f.spec, out, o);
  const RasterTile& t = job.tiles()[7];
  const std::string path =
      o.work_dir + "/tile_" + std::to_string(t.row) + "_" + std::to_string(t.col) + ".bin";
  ASSERT_TRUE(fs::exists(path));
  {
    std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(100);
    file.put('\x7f');
  }
  bool stale = false;
  EXPECT_FALSE(job.complete(t, &stale));
  EXPECT_TRUE(stale);
  // The stale tile is found while the GeoTIFF is being written: the error names the tile, the
  // previous GeoTIFF stays, and no partial file is left beside it.
  try {
    job.assemble();
    ADD_FAILURE() << "assemble() accepted a corrupt tile";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_EQ(potmap::test::file_bytes(out), first);
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_TRUE(e.path() == out || e.path() == o.work_dir ||
                e.path().filename() == "map.tif.manifest.json")
        << e.path();
  // A missing tile fails before anything is written.
  const RasterTile& t2 = job.tiles()[3];
  const std::string path2 =
      o.work_dir + "/tile_" + std::to_string(t2.row) + "_" + std::to_string(t2.col) + ".bin";
  const std::string saved = potmap::test::file_bytes(path2);
  fs::remove(path2);
  try {
    job.assemble();
    ADD_FAILURE() << "assemble() accepted a missing tile";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path2), std::string::npos) << e.what();
  }
  EXPECT_EQ(potmap::test::file_bytes(out), first);
  std::ofstream(path2, std::ios::binary) << saved;

  const TiledRasterSummary s = rasterize_tiled(test::context(), f.scene.map, f.spec, out, o);
  EXPECT_EQ(s.stale, 1u);
  EXPECT_EQ(s.computed, 1u);
  EXPECT_EQ(potmap::test::file_bytes(out), first);

  // Another map: every tile there belongs to another job.
  KernelMap other = f.scene.map;
  other.w_mean[0] += 1.0;
  const TiledRasterSummary s2 = rasterize_tiled(test::context(), other, f.spec, out, o);
  EXPECT_EQ(s2.stale, s2.tiles);
  EXPECT_EQ(s2.reused, 0u);
}

TEST(RasterTiles, BadOptionsAreNamed) {
  TilesFixture f;
  const std::string dir = test::temp_dir("raster-tiles-bad");
  TiledRasterOptions o = f.options(dir);
  o.tile_cells = 100;
  try {
    TiledRaster job(test::context(), f.scene.map, f.spec, dir + "/x.tif", o);
    FAIL() << "expected an error";
  } catch (const ArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("100"), std::string::npos) << e.what();
  }
  if (!geotiff_supported()) return;
  o.tile_cells = 64;
  o.crs = "NOT-A-CRS:42";
  try {
    rasterize_tiled(test::context(), f.scene.map, f.spec, dir + "/y.tif", o);
    FAIL() << "expected an error";
  } catch (const ArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("NOT-A-CRS:42"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir + "/y.tif"));
}

TEST(RasterTiles, ALevelChangesTheBytesNotTheValuesAndItsTilesAreRecomputed) {
  if (!geotiff_supported()) GTEST_SKIP() << "built without GDAL";
  TilesFixture f;
  const std::string dir = test::temp_dir("raster-tiles-levels");
  TiledRasterOptions o = f.options(dir + "/work");
  o.remove_tiles = false;
  const std::string out = dir + "/map.tif";
  std::vector<float> reference;
  std::string previous;
  for (int level : {0, 1, -20, 19}) {
    o.compression_level = level;
    const TiledRasterSummary s = rasterize_tiled(test::context(), f.scene.map, f.spec, out, o);
    // The tiles of the run before hold blocks of another level: none is reused.
    EXPECT_EQ(s.computed, s.tiles) << level;
    EXPECT_EQ(s.stale, previous.empty() ? 0u : s.tiles) << level;
    const std::string bytes = potmap::test::file_bytes(out);
    EXPECT_NE(bytes, previous) << "level " << level << " wrote the file of the level before";
    previous = bytes;
    const detail::GeoTiffImage prob = detail::read_geotiff_band(out, 1);
    EXPECT_EQ(prob.layout, "COG") << level;
    if (reference.empty()) reference = prob.values;
    ASSERT_EQ(prob.values.size(), reference.size());
    for (std::size_t i = 0; i < reference.size(); ++i)
      ASSERT_TRUE(prob.values[i] == reference[i] ||
                  (std::isnan(prob.values[i]) && std::isnan(reference[i])))
          << "level " << level << " pixel " << i;
  }
  // The same level again reuses every tile.
  const TiledRasterSummary again = rasterize_tiled(test::context(), f.scene.map, f.spec, out, o);
  EXPECT_EQ(again.reused, again.tiles);
  EXPECT_EQ(potmap::test::file_bytes(out), previous);

  const std::vector<std::pair<std::string, int>> bad = {
      {"ZSTD", 23}, {"ZSTD", -21}, {"DEFLATE", 10}, {"DEFLATE", -1}, {"LZW", 5}, {"NONE", 1}};
  for (const auto& [codec, level] : bad) {
    o.compression = codec;
    o.compression_level = level;
    try {
      TiledRaster job(test::context(), f.scene.map, f.spec, dir + "/bad.tif", o);
      ADD_FAILURE() << codec << " level " << level << " accepted";
    } catch (const ArgumentError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("level " + std::to_string(level) + " for " + codec), std::string::npos)
          << what;
      EXPECT_NE(what.find("bad.tif"), std::string::npos) << what;
    }
  }
}

TEST(RasterTiles, EveryCodecHoldsTheSameValues) {
  if (!geotiff_supported()) GTEST_SKIP() << "built without GDAL";
  TilesFixture f;
  const std::string dir = test::temp_dir("raster-tiles-codecs");
  TiledRasterOptions o = f.options(dir);
  EXPECT_EQ(o.compression, "ZSTD");
  std::vector<float> reference;
  for (const char* codec : {"ZSTD", "none", "Deflate", "LZW"}) {
    o.compression = codec;
    const std::string out = dir + "/map-" + codec + ".tif";
    const TiledRasterSummary s = rasterize_tiled(test::context(), f.scene.map, f.spec, out, o);
    const detail::GeoTiffImage prob = detail::read_geotiff_band(out, 1);
    std::string upper = codec;
    for (char& ch : upper) ch = char(std::toupper(static_cast<unsigned char>(ch)));
    EXPECT_EQ(prob.compression, upper == "NONE" ? "" : upper) << codec;
    EXPECT_EQ(prob.block_x, 64u) << codec;
    EXPECT_GE(prob.overviews, 1u) << codec;
    // The Cloud-Optimized layout's header before the first directory, for every codec (GDAL
    // 3.6's COG driver writes none for an uncompressed file; this writer does), which GDAL
    // checks against the file when it reports LAYOUT=COG.
    const std::string head = potmap::test::file_bytes(out).substr(0, 400);
    EXPECT_NE(head.find("LAYOUT=IFDS_BEFORE_DATA"), std::string::npos) << codec;
    EXPECT_NE(head.find("KNOWN_INCOMPATIBLE_EDITION=NO"), std::string::npos) << codec;
    EXPECT_EQ(prob.layout, "COG") << codec;
    EXPECT_EQ(s.computed, s.tiles) << codec;  // a tile holds its block compressed: per codec
    if (reference.empty()) {
      reference = prob.values;
      continue;
    }
    ASSERT_EQ(prob.values.size(), reference.size());
    for (std::size_t i = 0; i < reference.size(); ++i)
      ASSERT_TRUE(prob.values[i] == reference[i] ||
                  (std::isnan(prob.values[i]) && std::isnan(reference[i])))
          << codec << " pixel " << i;
  }
  o.compression = "jpeg";
  try {
    TiledRaster job(test::context(), f.scene.map, f.spec, dir + "/bad.tif", o);
    FAIL() << "expected an error";
  } catch (const ArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("'JPEG'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.tif"), std::string::npos) << e.what();
  }
}
