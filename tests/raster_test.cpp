#include <gtest/gtest.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>

#include "io/npy_writer.hpp"
#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/raster.hpp"
#include "render/png_writer.hpp"
#include "test_support.hpp"
#include "tuned_context.hpp"

namespace fs = std::filesystem;
using namespace potmap;

namespace {

struct Npy {
  std::size_t rows = 0, cols = 0;
  std::vector<float> data;
};

// An independent reader of what NumPy would accept: magic, version 1.0, '<f4', C order, shape.
Npy read_npy(const std::string& path) {
  const std::string s = potmap::test::file_bytes(path);
  if (s.size() < 10 || s.compare(0, 6, "\x93NUMPY") != 0) throw std::runtime_error("bad magic");
  if (s[6] != 1 || s[7] != 0) throw std::runtime_error("bad version");
  const std::size_t hlen = static_cast<unsigned char>(s[8]) | static_cast<unsigned char>(s[9]) << 8;
  if ((10 + hlen) % 64 != 0) throw std::runtime_error("data not 64-byte aligned");
  const std::string h = s.substr(10, hlen);
  if (h.back() != '\n') throw std::runtime_error("header does not end in newline");
  if (h.find("'descr': '<f4'") == std::string::npos) throw std::runtime_error("not <f4");
  if (h.find("'fortran_order': False") == std::string::npos) throw std::runtime_error("order");
  const std::size_t sp = h.find("'shape': (");
  if (sp == std::string::npos) throw std::runtime_error("no shape");
  Npy n;
  if (std::sscanf(h.c_str() + sp + 10, "%zu, %zu)", &n.rows, &n.cols) != 2)
    throw std::runtime_error("bad shape");
  if (s.size() != 10 + hlen + n.rows * n.cols * 4) throw std::runtime_error("bad data size");
  n.data.resize(n.rows * n.cols);
  std::memcpy(n.data.data(), s.data() + 10 + hlen, n.data.size() * 4);  // x86: little-endian
  return n;
}

struct Png {
  unsigned width = 0, height = 0;
  png_uint_32 format = 0;  // as stored, before conversion to RGB
  std::vector<std::uint8_t> rgb;
};

Png read_png(const std::string& path) {
  png_image img;
  std::memset(&img, 0, sizeof img);
  img.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&img, path.c_str()))
    throw std::runtime_error("libpng: " + std::string(img.message));
  EXPECT_EQ(img.format & PNG_FORMAT_FLAG_COLOR, PNG_FORMAT_FLAG_COLOR);
  EXPECT_EQ(img.format & PNG_FORMAT_FLAG_ALPHA, 0u);
  Png p;
  p.format = img.format;
  img.format = PNG_FORMAT_RGB;
  p.width = img.width;
  p.height = img.height;
  p.rgb.resize(PNG_IMAGE_SIZE(img));
  if (!png_image_finish_read(&img, nullptr, p.rgb.data(), 0, nullptr))
    throw std::runtime_error("libpng: " + std::string(img.message));
  return p;
}

KernelMap one_kernel_2d() {
  KernelMap m;
  m.dim = 2;
  const double pos[2] = {0.32, -0.45};
  m.push_back(pos, 2.0, 3.0, 0.8);
  return m;
}

RasterSpec small_window() {
  RasterSpec s;
  s.xmin = -2.0;
  s.xmax = 2.0;
  s.ymin = -1.5;
  s.ymax = 1.55;  // not a whole number of cells: height rounds up to 31
  s.resolution = 0.1;
  return s;
}

// Cell centres in raster order: row 0 = highest y.
std::vector<double> centres(const RasterSpec& s, int dim) {
  std::vector<double> pts;
  const std::size_t W = s.width(), H = s.height();
  for (std::size_t r = 0; r < H; ++r)
    for (std::size_t c = 0; c < W; ++c) {
      pts.push_back(s.xmin + (c + 0.5) * s.resolution);
      pts.push_back(s.ymin + (H - 1 - r + 0.5) * s.resolution);
      if (dim == 3) pts.push_back(s.z);
    }
  return pts;
}

double luminance(Rgb c) {
  return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b;
}

}  // namespace

TEST(Colormap, EndpointsAndMonotoneLightness) {
  const Rgb v0 = colormap(Colormap::Viridis, 0.0), v1 = colormap(Colormap::Viridis, 1.0);
  EXPECT_EQ(v0.r, 0x44);
  EXPECT_EQ(v0.g, 0x01);
  EXPECT_EQ(v0.b, 0x54);
  EXPECT_EQ(v1.r, 0xFD);
  EXPECT_EQ(v1.g, 0xE7);
  EXPECT_EQ(v1.b, 0x25);
  for (Colormap cm : {Colormap::Viridis, Colormap::Magma}) {
    double prev = -1;
    for (int i = 0; i <= 256; ++i) {
      const double l = luminance(colormap(cm, i / 256.0));
      // Allow a drop of a fraction of one 8-bit level: channels round at different t.
      EXPECT_GE(l, prev - 0.25) << "lightness must not drop, t = " << i / 256.0;
      prev = l;
    }
    EXPECT_GT(luminance(colormap(cm, 1.0)) - luminance(colormap(cm, 0.0)), 150);
  }
  // Out of range clamps; NaN is grey.
  EXPECT_EQ(colormap(Colormap::Magma, -3).r, colormap(Colormap::Magma, 0).r);
  EXPECT_EQ(colormap(Colormap::Magma, 7).g, colormap(Colormap::Magma, 1).g);
  EXPECT_EQ(colormap(Colormap::Viridis, std::nan("")).g, 128);
  EXPECT_EQ(parse_colormap("MAGMA"), Colormap::Magma);
  EXPECT_THROW(parse_colormap("jet"), ArgumentError);
}

TEST(Npy, HeaderIsAlignedAndNamesTheShape) {
  for (std::size_t rows : {1u, 31u, 123456789u}) {
    const std::string h = detail::NpyWriter::header(rows, 40);
    EXPECT_EQ(h.size() % 64, 0u);
    EXPECT_EQ(h.back(), '\n');
    EXPECT_NE(h.find("'shape': (" + std::to_string(rows) + ", 40)"), std::string::npos) << h;
  }
}

TEST(Npy, WriterOfSeveralWritebackStepsKeepsEveryByte) {
  // 2500 rows of 1000 floats: 10 MB, past AtomicFile's 8 MiB writeback step, in rows that do
  // not divide it; every value distinct, so a lost, repeated or reordered byte shows.
  const std::string path = test::temp_dir("npy-writeback") + "/a.npy";
  const std::size_t rows = 2500, cols = 1000;
  std::vector<float> row(cols);
  {
    detail::NpyWriter w(path, rows, cols);
    for (std::size_t r = 0; r < rows; ++r) {
      for (std::size_t c = 0; c < cols; ++c) row[c] = float(r * cols + c) * 0.5f;
      w.write_row(row.data());
    }
    w.finish();
  }
  const Npy a = read_npy(path);
  ASSERT_EQ(a.rows, rows);
  ASSERT_EQ(a.cols, cols);
  for (std::size_t i = 0; i < rows * cols; ++i) ASSERT_EQ(a.data[i], float(i) * 0.5f) << i;
}

TEST(PngWriter, IndexedPictureDecodesToItsPaletteColours) {
  const std::string dir = test::temp_dir("png-indexed");
  const std::vector<Rgb> palette = {{0, 0, 0}, {255, 128, 1}, {17, 34, 51}};
  const std::uint8_t rows[2][3] = {{0, 1, 2}, {2, 2, 1}};
  {
    detail::PngWriter w(dir + "/a.png", 3, 2, palette);
    w.write_row(rows[0]);
    w.write_row(rows[1]);
    w.finish();
  }
  const Png png = read_png(dir + "/a.png");
  ASSERT_EQ(png.width, 3u);
  ASSERT_EQ(png.height, 2u);
  EXPECT_NE(png.format & PNG_FORMAT_FLAG_COLORMAP, 0u);
  for (int r = 0; r < 2; ++r)
    for (int c = 0; c < 3; ++c) {
      const Rgb want = palette[rows[r][c]];
      const std::uint8_t* px = &png.rgb[3 * (r * 3 + c)];
      EXPECT_EQ(px[0], want.r) << r << "," << c;
      EXPECT_EQ(px[1], want.g) << r << "," << c;
      EXPECT_EQ(px[2], want.b) << r << "," << c;
    }
  // More than 256 colours is no PNG palette: the error names the file, which is not created.
  try {
    detail::PngWriter w(dir + "/b.png", 3, 2, std::vector<Rgb>(257));
    ADD_FAILURE() << "a palette of 257 colours was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("b.png"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir + "/b.png"));
  for (const auto& e : fs::directory_iterator(dir))
    EXPECT_EQ(e.path().filename(), "a.png");  // no temporary left behind
}

TEST(Raster, OneKernelMatchesTheExactReference) {
  const KernelMap map = one_kernel_2d();
  const RasterSpec spec = small_window();
  ASSERT_EQ(spec.width(), 40u);
  ASSERT_EQ(spec.height(), 31u);
  const std::string prefix = test::temp_dir("raster-exact") + "/town";
  const RasterSummary s = rasterize(test::context(), map, spec, prefix);
  EXPECT_EQ(s.cells, 40u * 31u);
  EXPECT_EQ(s.bands, 1u);
  ASSERT_EQ(s.files.size(), 4u);

  const Npy p = read_npy(prefix + "_prob.npy"), v = read_npy(prefix + "_var.npy");
  ASSERT_EQ(p.rows, 31u);
  ASSERT_EQ(p.cols, 40u);
  ASSERT_EQ(v.rows, 31u);
  ASSERT_EQ(v.cols, 40u);
  const std::vector<double> pts = centres(spec, 2);
  const MapValuesExact ex = evaluate_exact(map, pts.data(), p.data.size());
  float pmax = 0, vmin = 1e9;
  std::size_t argmax = 0;
  for (std::size_t i = 0; i < p.data.size(); ++i) {
    ASSERT_NEAR(p.data[i], ex.prob[i], 2e-6) << "cell " << i;
    ASSERT_NEAR(v.data[i], ex.var[i], 1e-5 * (1 + ex.var[i])) << "cell " << i;
    if (p.data[i] > pmax) pmax = p.data[i], argmax = i;
    vmin = std::min(vmin, v.data[i]);
  }
  // The peak lies in the cell holding the kernel (0.32, -0.45): row 0 is the top (y = 1.5).
  EXPECT_EQ(argmax % 40, 23u);
  EXPECT_EQ(argmax / 40, 31u - 1 - 10u);
  EXPECT_FLOAT_EQ(s.prob_max, pmax);
  EXPECT_FLOAT_EQ(s.var_min, vmin);
  EXPECT_GT(s.prob_max, 0.9f);
  EXPECT_NEAR(s.prob_min, 0.5f, 1e-3);  // far from the kernel mu = 0

  // The pictures decode, have the window's size and show the documented colours: the colour map
  // at round(254 t) / 254 exactly, so within a channel unit or two of the continuous map.
  const Png pp = read_png(prefix + "_prob.png"), vp = read_png(prefix + "_var.png");
  ASSERT_EQ(pp.width, 40u);
  ASSERT_EQ(pp.height, 31u);
  ASSERT_EQ(vp.width, 40u);
  ASSERT_EQ(vp.height, 31u);
  EXPECT_NE(pp.format & PNG_FORMAT_FLAG_COLORMAP, 0u);  // indexed colour
  EXPECT_NE(vp.format & PNG_FORMAT_FLAG_COLORMAP, 0u);
  int worst = 0;
  auto expect_colour = [&](const Png& png, std::size_t i, Colormap cm, double t) {
    const float c = std::clamp(float(t), 0.0f, 1.0f);
    const Rgb q = colormap(cm, std::floor(c * 254.0f + 0.5f) / 254.0);
    const Rgb exact = colormap(cm, t);
    const std::uint8_t* px = &png.rgb[3 * i];
    EXPECT_EQ(px[0], q.r) << i;
    EXPECT_EQ(px[1], q.g) << i;
    EXPECT_EQ(px[2], q.b) << i;
    for (int k = 0; k < 3; ++k) worst = std::max(worst, std::abs(int(px[k]) - int((&exact.r)[k])));
  };
  for (std::size_t i = 0; i < p.data.size(); ++i) {
    expect_colour(pp, i, Colormap::Viridis, p.data[i]);
    expect_colour(vp, i, Colormap::Magma, v.data[i] / (1.0 + v.data[i]));
  }
  EXPECT_LE(worst, 2);
}

TEST(Raster, BandsGiveTheSameFilesBitForBit) {
  // A window of 201 rows, so that bands of 64 rows (the band lattice) cut it several ways, with
  // several kernels of different reach. Under every raster.tile (16, 32, 64: divisors of the
  // lattice) the bands change nothing.
  KernelMap map = one_kernel_2d();
  const double p2[2] = {-1.0, 6.0}, p3[2] = {1.5, 12.0};
  map.push_back(p2, 0.05, -2.0, 3.0);
  map.push_back(p3, 1.0, 4.0, 0.2);
  RasterSpec spec = small_window();
  spec.ymax = spec.ymin + 20.05;  // 201 rows
  for (const int tile : {64, 32, 16}) {
    SCOPED_TRACE("raster.tile=" + std::to_string(tile));
    const auto tuned = test::tuned_context("raster.tile=" + std::to_string(tile));
    Context& ctx = *tuned;
    ASSERT_EQ(ctx.tuning().raster.tile, tile);
    const std::string dir = test::temp_dir("raster-bands-" + std::to_string(tile));
    rasterize(ctx, map, spec, dir + "/one");
    for (std::size_t band : {std::size_t(1), std::size_t(40 * 130), std::size_t(40 * 333)}) {
      SCOPED_TRACE(band);
      RasterOptions o;
      o.max_band_cells = band;
      std::vector<double> fractions;
      o.progress = [&](double f) { fractions.push_back(f); };
      const std::string prefix = dir + "/band" + std::to_string(band);
      const RasterSummary s = rasterize(ctx, map, spec, prefix, o);
      // Bands are whole multiples of 64 rows (at least one), counted from the bottom.
      const std::size_t rows = std::max<std::size_t>(64, band / 40 / 64 * 64);
      EXPECT_EQ(s.bands, (201 + rows - 1) / rows);
      ASSERT_EQ(fractions.size(), s.bands);
      EXPECT_DOUBLE_EQ(fractions.back(), 1.0);
      EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
      for (const char* suffix : {"_prob.npy", "_var.npy", "_prob.png", "_var.png"})
        EXPECT_TRUE(potmap::test::file_bytes(dir + "/one" + suffix) ==
                    potmap::test::file_bytes(prefix + suffix))
            << suffix;
    }
  }
}

TEST(Raster, SliceOfA3DMap) {
  KernelMap m;
  m.dim = 3;
  const double a[3] = {0.0, 0.0, 1.0}, b[3] = {0.5, 0.5, -2.0};
  m.push_back(a, 1.5, 2.0, 0.1);
  m.push_back(b, 1.0, -4.0, 2.0);
  RasterSpec spec = small_window();
  spec.z = 0.8;
  RasterOptions o;
  o.write_png = false;
  const std::string prefix = test::temp_dir("raster-3d") + "/slice";
  const RasterSummary s = rasterize(test::context(), m, spec, prefix, o);
  EXPECT_EQ(s.files.size(), 2u);
  EXPECT_FALSE(fs::exists(prefix + "_prob.png"));
  const Npy p = read_npy(prefix + "_prob.npy");
  const std::vector<double> pts = centres(spec, 3);
  const MapValuesExact ex = evaluate_exact(m, pts.data(), p.data.size());
  for (std::size_t i = 0; i < p.data.size(); ++i) ASSERT_NEAR(p.data[i], ex.prob[i], 2e-6) << i;
}

TEST(Raster, UnwritableFolderLeavesNothing) {
  // A missing folder is made; one cannot be made under a regular file.
  const std::string dir = test::temp_dir("raster-fail");
  { std::ofstream(dir + "/a-file") << "x"; }
  EXPECT_THROW(
      rasterize(test::context(), one_kernel_2d(), small_window(), dir + "/a-file/folder/out"),
      Error);
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(dir)) left.push_back(e.path().filename().string());
  EXPECT_EQ(left, std::vector<std::string>{"a-file"});
}

TEST(Raster, FailureMidRunRemovesTemporaryFiles) {
  const std::string dir = test::temp_dir("raster-abort");
  RasterOptions o;
  o.max_band_cells = 40 * 4;  // one 64-row band at a time
  RasterSpec spec = small_window();
  spec.ymax = spec.ymin + 20.05;  // 201 rows: four bands
  int calls = 0;
  o.progress = [&](double) {
    if (++calls == 3) throw std::runtime_error("stop");
  };
  EXPECT_THROW(rasterize(test::context(), one_kernel_2d(), spec, dir + "/out", o),
               std::runtime_error);
  EXPECT_EQ(calls, 3);
  EXPECT_TRUE(fs::is_empty(dir)) << fs::directory_iterator(dir)->path();
}

TEST(Raster, BadWindowNamesTheValue) {
  RasterSpec s = small_window();
  s.xmax = s.xmin;
  try {
    rasterize(test::context(), one_kernel_2d(), s, test::temp_dir("raster-bad") + "/x");
    FAIL() << "expected ArgumentError";
  } catch (const ArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("xmin"), std::string::npos) << e.what();
  }
  s = small_window();
  s.resolution = -1;
  EXPECT_THROW(s.validate(), ArgumentError);
  s = small_window();
  s.ymin = std::nan("");
  try {
    s.validate();
    FAIL();
  } catch (const ArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("ymin"), std::string::npos) << e.what();
  }
}
