#include "potmap/map/raster_tiles.hpp"

#include <cctype>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <sstream>
#include <unordered_map>

#include "io/atomic_file.hpp"
#include "io/container.hpp"
#include "io/geotiff_writer.hpp"
#include "io/text_io.hpp"
#include "map/raster_window.hpp"
#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/version.h"
#include "runtime/hash.hpp"
#include "runtime/serial_worker.hpp"

namespace potmap {

namespace fs = std::filesystem;

namespace {

using detail::hex64;

// A finished tile: the job's fingerprint, the tile's place, the size of its compressed block
// and of its first overview level; then that level (each band (width + 1) / 2 x (height + 1) / 2
// float32, image order; none without overviews) and the block as the GeoTIFF stores it
// (detail::encode_block: both bands, compressed once, copied into the GeoTIFF as they are).
constexpr std::size_t kTileHeader = 64;
constexpr detail::ContainerLayout kTileLayout{"POTTILE\n", "a potmap raster tile", 2, kTileHeader,
                                              16};
constexpr std::size_t kBands = 2;  // probability, variance

// The codec and level of a tile's block, in its header (offset 12: the codec's number in the
// low byte, the level plus 128 above it): a tile of another codec or level is recomputed. Not
// part of the job's fingerprint, which the GeoTIFF's metadata holds.
std::uint32_t codec_id(const std::string& compression, int level) {
  const char* names[] = {"ZSTD", "DEFLATE", "LZW", "NONE"};
  const auto l = std::uint32_t(detail::default_level(compression, level) + 128) << 8;
  for (std::uint32_t i = 0; i < 4; ++i)
    if (compression == names[i]) return (i + 1) | l;
  return 0;
}

std::uint64_t hash_doubles(const std::vector<double>& v, std::uint64_t h) {
  return detail::fnv1a64(
      std::string_view(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double)), h);
}
template <class T>
std::uint64_t hash_value(T v, std::uint64_t h) {
  return detail::fnv1a64(std::string_view(reinterpret_cast<const char*>(&v), sizeof v), h);
}

// Everything a tile's values depend on: the map, the window, the height band's levels (a slice
// hashes as before), the tile size, the evaluator's cut-off, and the version of the code that
// computes them.
std::uint64_t job_fingerprint(const KernelMap& m, const RasterSpec& s, const TiledRasterOptions& o,
                              const std::vector<double>& levels) {
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
  if (!levels.empty()) h = hash_doubles(levels, detail::fnv1a64("height band", h));
  return hash_value(static_cast<std::uint64_t>(o.tile_cells), h);
}

// The first overview levels that a job keeps in memory from the tiles it stores, so that its
// assembly copies them instead of reading each tile file back and checking it again: a quarter
// of each tile's bands, 128 MiB for 64 M cells. Past the bound the assembly reads the files.
constexpr std::size_t kKeptHalvesBytes = std::size_t(256) << 20;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The shortest text that reads back as the same double.
std::string num(double v) {
  return detail::format_double(v);
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
  std::vector<double> levels;                          // the height band's (empty for a slice)
  std::unique_ptr<detail::WindowEvaluator> evaluator;  // made on first use: the assembling rank
                                                       // needs none
  std::vector<float> eval_prob, eval_var;              // evaluate()'s, reused tile after tile

  // What store() wrote, for the assembly: the file's checksum and block size, and (up to
  // kKeptHalvesBytes in all) its first overview level.
  struct Stored {
    std::uint32_t crc = 0;
    std::uint64_t block_bytes = 0;
    std::vector<float> halves;  // the bands one after the other; empty past the bound
  };
  mutable std::mutex stored_mutex;
  mutable std::unordered_map<std::size_t, Stored> stored;
  mutable std::size_t stored_bytes = 0;

  Impl(Context& c, const KernelMap& m) : ctx(c), map(m) {}

  std::string tile_path(const RasterTile& t) const {
    return (fs::path(options.work_dir) /
            ("tile_" + std::to_string(t.row) + "_" + std::to_string(t.col) + ".bin"))
        .string();
  }

  // The GeoTIFF's layout, bands and codec (the georeferencing: assemble()).
  detail::GeoTiffSpec geotiff() const {
    detail::GeoTiffSpec g;
    g.width = width;
    g.height = height;
    g.block = options.tile_cells;
    g.overviews = options.overviews;
    g.compression = options.compression;
    g.level = options.compression_level;
    g.band_names = {"probability", "variance"};
    return g;
  }

  // Where a tile file's parts are.
  struct TileParts {
    std::size_t half_w = 0, half_h = 0;           // its first overview level, a band
    std::uint64_t block_at = 0, block_bytes = 0;  // its compressed block
  };

  // This job's record of the tile, if it stored it and kept what the assembly needs (its first
  // overview level, when `bands` of it are wanted).
  const Stored* kept(const RasterTile& t, std::size_t bands) const {
    std::lock_guard<std::mutex> lock(stored_mutex);
    const auto it = stored.find(t.index);
    if (it == stored.end()) return nullptr;
    const bool has_halves = !options.overviews || !it->second.halves.empty();
    return bands == 0 || has_halves ? &it->second : nullptr;
  }

  // The tile's file, checked: its job, its place and sizes, its checksum (put in `crc` unless
  // null). Its first overview level goes to `halves` (a band each) unless that is empty.
  TileParts read(const RasterTile& t, const std::vector<float*>& halves,
                 std::uint32_t* crc = nullptr, std::string* block = nullptr) const {
    const std::string path = tile_path(t);
    detail::ContainerReader r(path, kTileLayout);
    TileParts p;
    const std::uint32_t codec = codec_id(options.compression, options.compression_level);
    if (r.u32(12) != codec)
      r.fail(12, "block compressed with codec " + std::to_string(r.u32(12) & 0xff) + " level " +
                     std::to_string(int(r.u32(12) >> 8) - 128) + ", this job " +
                     std::to_string(codec & 0xff) + " (" + options.compression + ") level " +
                     std::to_string(
                         detail::default_level(options.compression, options.compression_level)));
    p.block_bytes = r.u64(48);
    p.half_w = r.u32(56);
    p.half_h = r.u32(60);
    const std::size_t want_w = options.overviews ? (t.width + 1) / 2 : 0;
    const std::size_t want_h = options.overviews ? (t.height + 1) / 2 : 0;
    if (p.half_w != want_w || p.half_h != want_h)
      r.fail(56, "first overview level of " + std::to_string(p.half_w) + " x " +
                     std::to_string(p.half_h) + " cells, expected " + std::to_string(want_w) +
                     " x " + std::to_string(want_h));
    const std::uint64_t halves_bytes = 4 * kBands * p.half_w * p.half_h;
    p.block_at = kTileHeader + halves_bytes;
    r.check_size(p.block_bytes < (std::uint64_t(1) << 40) ? p.block_at + p.block_bytes + 4 : 0, 48,
                 "a tile whose block has " + std::to_string(p.block_bytes) + " bytes");
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
    const std::size_t n = p.half_w * p.half_h;
    for (std::size_t b = 0; b < halves.size() && b < kBands; ++b) {
      const std::size_t at = kTileHeader + 4 * b * n;
      if (detail::host_is_little_endian())
        std::memcpy(halves[b], r.data() + at, 4 * n);
      else
        for (std::size_t i = 0; i < n; ++i) halves[b][i] = r.f32(at + 4 * i);
    }
    if (block) block->assign(reinterpret_cast<const char*>(r.data()) + p.block_at, p.block_bytes);
    return p;
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
  detail::check_level(options.compression, options.compression_level, output);
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
  im.levels = raster_levels(spec, map);  // a bad band fails before any tile
  im.fingerprint = job_fingerprint(map, spec, im.options, im.levels);
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
    impl_->read(tile, {});
    return true;
  } catch (const Error&) {
    if (stale) *stale = true;
    return false;
  }
}

void TiledRaster::evaluate(const RasterTile& t, std::vector<float>& prob, std::vector<float>& var) {
  Impl& im = *impl_;
  if (!im.evaluator)
    im.evaluator =
        std::make_unique<detail::WindowEvaluator>(im.ctx, im.map, im.spec, im.options.eval);
  // Image rows y0 .. y0 + h - 1 are grid rows (counted from the bottom) H - y0 - h .. H - y0 - 1.
  const std::size_t n = t.width * t.height;
  std::vector<float>& p = im.eval_prob;
  std::vector<float>& v = im.eval_var;
  p.resize(n);
  v.resize(n);
  im.evaluator->rows(t.x0, t.width, im.height - t.y0 - t.height, t.height, v.data(), p.data());
  prob.resize(n);
  var.resize(n);
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
  const Impl& im = *impl_;
  const std::string path = im.tile_path(t);
  const std::string block =
      detail::encode_block(path, im.geotiff(), {prob.data(), var.data()}, t.width, t.height);
  const std::size_t hw = im.options.overviews ? (t.width + 1) / 2 : 0;
  const std::size_t hh = im.options.overviews ? (t.height + 1) / 2 : 0;
  thread_local std::vector<float> half;  // reused: store() runs tile after tile on one thread
  half.resize(hw * hh);
  Impl::Stored kept;
  kept.block_bytes = block.size();
  bool keep;
  {
    std::lock_guard<std::mutex> lock(im.stored_mutex);
    keep = im.stored_bytes + 4 * kBands * half.size() <= kKeptHalvesBytes;
    if (keep) im.stored_bytes += 4 * kBands * half.size();
  }
  if (keep) kept.halves.reserve(kBands * half.size());
  detail::ContainerWriter w(kTileLayout, kTileHeader + 4 * kBands * half.size() + block.size() + 4);
  w.u32(codec_id(im.options.compression, im.options.compression_level));
  w.u64(0);  // size, filled by finish()
  w.u64(im.fingerprint);
  w.u32(std::uint32_t(t.row));
  w.u32(std::uint32_t(t.col));
  w.u32(std::uint32_t(t.width));
  w.u32(std::uint32_t(t.height));
  w.u64(block.size());
  w.u32(std::uint32_t(hw));
  w.u32(std::uint32_t(hh));
  for (const std::vector<float>* band : {&prob, &var}) {
    if (half.empty()) break;
    detail::average_halves(band->data(), t.width, t.height, half.data());
    w.f32s(half);
    if (keep) kept.halves.insert(kept.halves.end(), half.begin(), half.end());
  }
  w.bytes(block);
  kept.crc = w.finish(path);
  std::lock_guard<std::mutex> lock(im.stored_mutex);
  Impl::Stored& slot = im.stored[t.index];  // a tile stored again replaces its record
  im.stored_bytes -= 4 * slot.halves.size();
  slot = std::move(kept);
}

void TiledRaster::load(const RasterTile& t, std::vector<float>& prob,
                       std::vector<float>& var) const {
  const Impl& im = *impl_;
  std::string block;
  im.read(t, {}, nullptr, &block);
  prob.resize(t.width * t.height);
  var.resize(t.width * t.height);
  detail::decode_block(im.tile_path(t), im.geotiff(), block, t.width, t.height,
                       {prob.data(), var.data()});
}

TiledRasterSummary TiledRaster::assemble(const std::function<void(double)>& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  Impl& im = *impl_;
  // A missing tile fails before any output is started. Each tile that this job did not store
  // itself is checked in full (job, place, checksum) as it is read for the GeoTIFF, once: a
  // stale one fails there, naming the file, offset and value, and the partial GeoTIFF is
  // removed. The tiles it stored come from its record of them (store()), not read back.
  for (const RasterTile& t : im.tiles) {
    std::error_code ec;
    if (!fs::exists(im.tile_path(t), ec))
      throw Error(im.tile_path(t) + ": tile (" + std::to_string(t.row) + ", " +
                  std::to_string(t.col) + ") of the raster job is missing");
  }
  std::vector<std::uint32_t> crcs(im.tiles.size(), 0);
  detail::GeoTiffSpec g = im.geotiff();
  g.left = im.spec.xmin;
  g.top = im.spec.ymin + double(im.height) * im.spec.resolution;
  g.pixel = im.spec.resolution;
  g.crs = im.options.crs;
  g.metadata = {{"POTMAP_VERSION", POTMAP_VERSION_STRING},
                {"POTMAP_JOB", hex64(im.fingerprint)},
                {"POTMAP_Z", num(im.spec.z)}};
  if (!im.levels.empty())  // what the bands hold: the maximum over these heights
    g.metadata.push_back({"POTMAP_HEIGHT_BAND", num(im.levels.front()) + " " +
                                                    num(im.levels.back()) + " " +
                                                    std::to_string(im.levels.size())});
  // Each tile's block goes into the GeoTIFF as the tile file holds it: compressed once, when
  // the tile was computed.
  detail::write_cog_encoded(
      im.output, g,
      [&](std::size_t row, std::size_t col, const std::vector<float*>& halves) {
        const RasterTile& t = im.tiles.at(row * im.cols + col);
        if (const Impl::Stored* s = im.kept(t, halves.size())) {
          crcs[t.index] = s->crc;
          const std::size_t n = s->halves.size() / kBands;
          for (std::size_t b = 0; b < halves.size() && b < kBands; ++b)
            std::memcpy(halves[b], s->halves.data() + b * n, 4 * n);
          return detail::EncodedBlock{im.tile_path(t), kTileHeader + 4 * s->halves.size(),
                                      s->block_bytes};
        }
        const Impl::TileParts p = im.read(t, halves, &crcs[t.index]);
        return detail::EncodedBlock{im.tile_path(t), p.block_at, p.block_bytes};
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
  s.levels = im.levels.size();
  if (s.levels > 1) s.level_spacing = im.levels[1] - im.levels[0];
  s.output = im.output;
  s.seconds = seconds_since(t0);
  return s;
}

TiledRasterSummary compute_tiles(TiledRaster& job, const std::function<std::size_t()>& next,
                                 const std::function<void(std::size_t)>& done) {
  TiledRasterSummary s;
  const std::size_t total = job.tiles().size();
  // Writing tile k overlaps evaluating tile k + 1; two sets of buffers take turns. The writer
  // is one thread for the whole run, so its buffers are reused from tile to tile.
  std::vector<float> prob[2], var[2];
  int slot = 0;
  detail::SerialWorker writer;
  double& store_s = s.store_seconds;
  for (std::size_t i = next(); i < total; i = next()) {
    const RasterTile& t = job.tiles()[i];
    bool was_stale = false;
    if (job.complete(t, &was_stale)) {
      ++s.reused;
    } else {
      s.stale += was_stale;
      auto at = std::chrono::steady_clock::now();
      job.evaluate(t, prob[slot], var[slot]);
      s.evaluate_seconds += seconds_since(at);
      at = std::chrono::steady_clock::now();
      writer.submit([&job, &store_s, t, &p = prob[slot], &v = var[slot]] {
        const auto t1 = std::chrono::steady_clock::now();
        job.store(t, p, v);
        store_s += seconds_since(t1);
      });  // rethrows a failed write of the tile before
      s.store_wait_seconds += seconds_since(at);
      slot ^= 1;
      ++s.computed;
    }
    if (done) done(i);
  }
  const auto at = std::chrono::steady_clock::now();
  writer.wait();
  s.store_wait_seconds += seconds_since(at);
  return s;
}

TiledRasterSummary rasterize_tiled(Context& ctx, const KernelMap& map, const RasterSpec& spec,
                                   const std::string& output, const TiledRasterOptions& options,
                                   const std::function<void(double)>& progress) {
  const auto t0 = std::chrono::steady_clock::now();
  TiledRaster job(ctx, map, spec, output, options);
  const std::size_t total = job.tiles().size();
  std::size_t handed = 0, done = 0;
  const TiledRasterSummary run = compute_tiles(
      job, [&] { return handed++; },
      [&](std::size_t) {
        if (progress) progress(0.9 * double(++done) / double(total));
      });
  const auto assembling = std::chrono::steady_clock::now();
  TiledRasterSummary s = job.assemble(
      progress ? std::function<void(double)>([&](double f) { progress(0.9 + 0.1 * f); })
               : std::function<void(double)>());
  s.computed = run.computed;
  s.reused = run.reused;
  s.stale = run.stale;
  s.evaluate_seconds = run.evaluate_seconds;
  s.store_seconds = run.store_seconds;
  s.store_wait_seconds = run.store_wait_seconds;
  s.assemble_seconds = seconds_since(assembling);
  s.seconds = seconds_since(t0);
  return s;
}

bool geotiff_supported() {
  return detail::geotiff_available();
}

}  // namespace potmap
