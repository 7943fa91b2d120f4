#include "potmap/map/raster_tiles.hpp"

#include <cctype>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <future>
#include <sstream>

#include "io/atomic_file.hpp"
#include "io/container.hpp"
#include "io/geotiff_writer.hpp"
#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/version.h"
#include "runtime/hash.hpp"

namespace potmap {

namespace fs = std::filesystem;

namespace {

using detail::hex64;

// A finished tile: the job's fingerprint and the tile's place, then probability and variance
// in image order (row 0 = top), float32.
constexpr std::size_t kTileHeader = 48;
constexpr detail::ContainerLayout kTileLayout{"POTTILE\n", "a potmap raster tile", 1, kTileHeader,
                                              16};

std::uint64_t hash_doubles(const std::vector<double>& v, std::uint64_t h) {
  return detail::fnv1a64(
      std::string_view(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double)), h);
}
template <class T>
std::uint64_t hash_value(T v, std::uint64_t h) {
  return detail::fnv1a64(std::string_view(reinterpret_cast<const char*>(&v), sizeof v), h);
}

// Everything a tile's values depend on: the map, the window, the tile size, the evaluator's
// cut-off, and the version of the code that computes them.
std::uint64_t job_fingerprint(const KernelMap& m, const RasterSpec& s,
                              const TiledRasterOptions& o) {
  std::uint64_t h = detail::fnv1a64("potmap raster tiles " POTMAP_VERSION_STRING);
  h = hash_value(m.dim, h);
  h = hash_doubles(m.position, h);
  h = hash_doubles(m.gamma, h);
  h = hash_doubles(m.w_mean, h);
  h = hash_doubles(m.w_var, h);
  h = hash_value(m.has_bias, h);
  h = hash_value(m.bias_mean, h);
  h = hash_value(m.bias_var, h);
  for (double v : {s.xmin, s.xmax, s.ymin, s.ymax, s.resolution, s.z, o.eval.tau})
    h = hash_value(v, h);
  return hash_value(static_cast<std::uint64_t>(o.tile_cells), h);
}

std::string num(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

}  // namespace

struct TiledRaster::Impl {
  Context& ctx;
  const KernelMap& map;
  RasterSpec spec;
  std::string output;
  TiledRasterOptions options;
  std::size_t width = 0, height = 0, cols = 0, rows = 0;
  std::vector<RasterTile> tiles;
  std::uint64_t fingerprint = 0;
  std::unique_ptr<MapEvaluator> evaluator;  // made on first use: the assembling rank needs none

  Impl(Context& c, const KernelMap& m) : ctx(c), map(m) {}

  std::string tile_path(const RasterTile& t) const {
    return (fs::path(options.work_dir) /
            ("tile_" + std::to_string(t.row) + "_" + std::to_string(t.col) + ".bin"))
        .string();
  }

  // The tile's file, checked: its job, its place and size, its checksum (put in `crc` unless
  // null).
  void read(const RasterTile& t, std::vector<float>* prob, std::vector<float>* var,
            std::uint32_t* crc = nullptr) const {
    const std::string path = tile_path(t);
    detail::ContainerReader r(path, kTileLayout);
    const std::size_t n = t.width * t.height;
    r.check_size(kTileHeader + 8 * n + 4, 16, "a tile of " + std::to_string(n) + " cells");
    r.check_checksum();
    if (r.u64(24) != fingerprint)
      r.fail(24, "tile of another job (fingerprint " + hex64(r.u64(24)) + ", this job " +
                     hex64(fingerprint) + ")");
    const std::uint32_t want[4] = {std::uint32_t(t.row), std::uint32_t(t.col),
                                   std::uint32_t(t.width), std::uint32_t(t.height)};
    const char* names[4] = {"tile row", "tile column", "width", "height"};
    for (int i = 0; i < 4; ++i)
      if (r.u32(32 + 4 * i) != want[i])
        r.fail(32 + 4 * i, std::string(names[i]) + " " + std::to_string(r.u32(32 + 4 * i)) +
                               ", expected " + std::to_string(want[i]));
    if (crc) *crc = r.u32(r.payload_end());
    if (prob && var) {
      prob->resize(n);
      var->resize(n);
      if (detail::host_is_little_endian()) {
        std::memcpy(prob->data(), r.data() + kTileHeader, 4 * n);
        std::memcpy(var->data(), r.data() + kTileHeader + 4 * n, 4 * n);
      } else {
        for (std::size_t i = 0; i < n; ++i) (*prob)[i] = r.f32(kTileHeader + 4 * i);
        for (std::size_t i = 0; i < n; ++i) (*var)[i] = r.f32(kTileHeader + 4 * (n + i));
      }
    }
  }
};

TiledRaster::TiledRaster(Context& ctx, const KernelMap& map, const RasterSpec& spec,
                         std::string output, TiledRasterOptions options)
    : impl_(std::make_unique<Impl>(ctx, map)) {
  spec.validate();
  map.validate();
  if (output.empty()) throw ArgumentError("raster: empty output path");
  if (options.tile_cells == 0 || options.tile_cells % 64 || options.tile_cells > 8192)
    throw ArgumentError("raster: tile size " + std::to_string(options.tile_cells) +
                        " cells; must be a multiple of 64 from 64 to 8192");
  detail::check_crs(options.crs, output);  // before any tile is computed
  for (char& ch : options.compression) ch = char(std::toupper(static_cast<unsigned char>(ch)));
  detail::check_compression(options.compression, output);
  if (options.work_dir.empty()) options.work_dir = output + ".tiles";
  Impl& im = *impl_;
  im.spec = spec;
  im.output = std::move(output);
  im.options = std::move(options);
  im.width = spec.width();
  im.height = spec.height();
  const std::size_t T = im.options.tile_cells;
  im.cols = (im.width + T - 1) / T;
  im.rows = (im.height + T - 1) / T;
  for (std::size_t r = 0; r < im.rows; ++r)
    for (std::size_t c = 0; c < im.cols; ++c) {
      RasterTile t;
      t.row = r;
      t.col = c;
      t.x0 = c * T;
      t.y0 = r * T;
      t.width = std::min(T, im.width - t.x0);
      t.height = std::min(T, im.height - t.y0);
      t.index = r * im.cols + c;
      im.tiles.push_back(t);
    }
  im.fingerprint = job_fingerprint(map, spec, im.options);
  std::error_code ec;
  fs::create_directories(im.options.work_dir, ec);
  if (ec || !fs::is_directory(im.options.work_dir))
    throw Error(im.options.work_dir + ": cannot create the work folder of the raster tiles" +
                (ec ? ": " + ec.message() : std::string()));
}

TiledRaster::~TiledRaster() = default;

const std::vector<RasterTile>& TiledRaster::tiles() const {
  return impl_->tiles;
}
std::size_t TiledRaster::width() const {
  return impl_->width;
}
std::size_t TiledRaster::height() const {
  return impl_->height;
}
std::uint64_t TiledRaster::fingerprint() const {
  return impl_->fingerprint;
}
const std::string& TiledRaster::work_dir() const {
  return impl_->options.work_dir;
}

bool TiledRaster::complete(const RasterTile& tile, bool* stale) const {
  if (stale) *stale = false;
  std::error_code ec;
  if (!fs::exists(impl_->tile_path(tile), ec)) return false;
  try {
    impl_->read(tile, nullptr, nullptr);
    return true;
  } catch (const Error&) {
    if (stale) *stale = true;
    return false;
  }
}

void TiledRaster::evaluate(const RasterTile& t, std::vector<float>& prob, std::vector<float>& var) {
  Impl& im = *impl_;
  if (!im.evaluator) im.evaluator = std::make_unique<MapEvaluator>(im.ctx, im.map, im.options.eval);
  // Image rows y0 .. y0 + h - 1 are grid rows (counted from the bottom) H - y0 - h .. H - y0 - 1.
  GridSpec g;
  g.dim = im.map.dim;
  g.resolution = im.spec.resolution;
  g.origin[0] = im.spec.xmin + double(t.x0) * im.spec.resolution;
  g.origin[1] = im.spec.ymin + double(im.height - t.y0 - t.height) * im.spec.resolution;
  g.origin[2] = im.spec.z - 0.5 * im.spec.resolution;  // one layer centred on z (3D maps)
  g.count[0] = t.width;
  g.count[1] = t.height;
  g.count[2] = 1;
  std::vector<float> p(g.cells()), v(g.cells());
  im.evaluator->evaluate_grid(g, nullptr, v.data(), p.data());
  prob.resize(g.cells());
  var.resize(g.cells());
  for (std::size_t r = 0; r < t.height; ++r) {  // grid rows run up, image rows down
    const std::size_t from = (t.height - 1 - r) * t.width;
    std::memcpy(prob.data() + r * t.width, p.data() + from, t.width * sizeof(float));
    std::memcpy(var.data() + r * t.width, v.data() + from, t.width * sizeof(float));
  }
}

void TiledRaster::store(const RasterTile& t, const std::vector<float>& prob,
                        const std::vector<float>& var) const {
  const std::size_t n = t.width * t.height;
  if (prob.size() != n || var.size() != n)
    throw ArgumentError("raster tile (" + std::to_string(t.row) + ", " + std::to_string(t.col) +
                        "): " + std::to_string(prob.size()) + " and " + std::to_string(var.size()) +
                        " values for " + std::to_string(n) + " cells");
  detail::ContainerWriter w(kTileLayout, kTileHeader + 8 * n + 4);
  w.u32(0);  // reserved
  w.u64(0);  // size, filled by finish()
  w.u64(impl_->fingerprint);
  w.u32(std::uint32_t(t.row));
  w.u32(std::uint32_t(t.col));
  w.u32(std::uint32_t(t.width));
  w.u32(std::uint32_t(t.height));
  w.f32s(prob);
  w.f32s(var);
  w.finish(impl_->tile_path(t));
}

void TiledRaster::load(const RasterTile& t, std::vector<float>& prob,
                       std::vector<float>& var) const {
  impl_->read(t, &prob, &var);
}

TiledRasterSummary TiledRaster::assemble(const std::function<void(double)>& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  Impl& im = *impl_;
  // A missing tile fails before any output is started. Each tile is checked in full (job,
  // place, checksum) as it is read for the GeoTIFF, once: a stale one fails there, naming the
  // file, offset and value, and the partial GeoTIFF is removed.
  for (const RasterTile& t : im.tiles) {
    std::error_code ec;
    if (!fs::exists(im.tile_path(t), ec))
      throw Error(im.tile_path(t) + ": tile (" + std::to_string(t.row) + ", " +
                  std::to_string(t.col) + ") of the raster job is missing");
  }
  std::vector<std::uint32_t> crcs(im.tiles.size(), 0);
  detail::GeoTiffSpec g;
  g.width = im.width;
  g.height = im.height;
  g.block = im.options.tile_cells;
  g.left = im.spec.xmin;
  g.top = im.spec.ymin + double(im.height) * im.spec.resolution;
  g.pixel = im.spec.resolution;
  g.crs = im.options.crs;
  g.overviews = im.options.overviews;
  g.compression = im.options.compression;
  g.band_names = {"probability", "variance"};
  g.metadata = {{"POTMAP_VERSION", POTMAP_VERSION_STRING},
                {"POTMAP_JOB", hex64(im.fingerprint)},
                {"POTMAP_Z", num(im.spec.z)}};
  std::vector<float> prob, var;
  detail::write_cog(
      im.output, g,
      [&](std::size_t x0, std::size_t y0, std::size_t w, std::size_t h, std::vector<float*>& b) {
        const RasterTile& t = im.tiles[(y0 / g.block) * im.cols + x0 / g.block];
        if (t.x0 != x0 || t.y0 != y0 || t.width != w || t.height != h)
          throw Error(im.output + ": internal: block (" + std::to_string(x0) + ", " +
                      std::to_string(y0) + ") is not a tile");
        im.read(t, &prob, &var, &crcs[t.index]);
        std::memcpy(b[0], prob.data(), prob.size() * sizeof(float));
        std::memcpy(b[1], var.data(), var.size() * sizeof(float));
      },
      progress);

  // The manifest: what the GeoTIFF was made of, with each tile's checksum.
  std::ostringstream m;
  m << "{\n  \"potmap_version\": \"" << POTMAP_VERSION_STRING << "\",\n  \"job\": \""
    << hex64(im.fingerprint) << "\",\n  \"output\": \"" << fs::path(im.output).filename().string()
    << "\",\n  \"width\": " << im.width << ",\n  \"height\": " << im.height
    << ",\n  \"tile_cells\": " << im.options.tile_cells << ",\n  \"window\": [" << num(im.spec.xmin)
    << ", " << num(im.spec.xmax) << ", " << num(im.spec.ymin) << ", " << num(im.spec.ymax)
    << "],\n  \"resolution\": " << num(im.spec.resolution) << ",\n  \"tiles\": [";
  for (std::size_t i = 0; i < im.tiles.size(); ++i) {
    const RasterTile& t = im.tiles[i];
    m << (i ? "," : "") << "\n    {\"row\": " << t.row << ", \"col\": " << t.col
      << ", \"x0\": " << t.x0 << ", \"y0\": " << t.y0 << ", \"width\": " << t.width
      << ", \"height\": " << t.height << ", \"crc32\": \"" << std::hex << crcs[i] << std::dec
      << "\"}";
  }
  m << "\n  ]\n}\n";
  TiledRasterSummary s;
  s.manifest = im.output + ".manifest.json";
  {
    detail::AtomicFile f(s.manifest);
    const std::string text = m.str();
    f.write(text.data(), text.size());
    f.commit();
  }
  if (im.options.remove_tiles) {
    // The tiles and any temporary a killed run left; the folder itself only if that empties
    // it, never a folder holding other files.
    std::error_code ec;
    std::vector<fs::path> ours;
    for (fs::directory_iterator it(im.options.work_dir, ec), end; !ec && it != end;
         it.increment(ec))
      if (it->path().filename().string().rfind("tile_", 0) == 0) ours.push_back(it->path());
    for (const fs::path& p : ours) fs::remove(p, ec);
    fs::remove(im.options.work_dir, ec);
  }
  s.width = im.width;
  s.height = im.height;
  s.tiles = im.tiles.size();
  s.output = im.output;
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

TiledRasterSummary rasterize_tiled(Context& ctx, const KernelMap& map, const RasterSpec& spec,
                                   const std::string& output, const TiledRasterOptions& options,
                                   const std::function<void(double)>& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  TiledRaster job(ctx, map, spec, output, options);
  std::size_t computed = 0, reused = 0, stale = 0;
  const std::size_t total = job.tiles().size();
  // Writing tile k overlaps evaluating tile k + 1; two sets of buffers take turns.
  std::vector<float> prob[2], var[2];
  std::future<void> writing;
  int slot = 0;
  std::size_t done = 0;
  for (const RasterTile& t : job.tiles()) {
    bool was_stale = false;
    if (job.complete(t, &was_stale)) {
      ++reused;
    } else {
      stale += was_stale;
      job.evaluate(t, prob[slot], var[slot]);
      if (writing.valid()) writing.get();  // rethrows a failed write
      writing = std::async(std::launch::async,
                           [&job, t, &p = prob[slot], &v = var[slot]] { job.store(t, p, v); });
      slot ^= 1;
      ++computed;
    }
    ++done;
    if (progress) progress(0.9 * double(done) / double(total));
  }
  if (writing.valid()) writing.get();
  TiledRasterSummary s = job.assemble(
      progress ? std::function<void(double)>([&](double f) { progress(0.9 + 0.1 * f); })
               : std::function<void(double)>());
  s.computed = computed;
  s.reused = reused;
  s.stale = stale;
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

bool geotiff_supported() {
  return detail::geotiff_available();
}

}  // namespace potmap
