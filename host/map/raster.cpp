#include "potmap/map/raster.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <future>
#include <limits>
#include <memory>

#include "io/npy_writer.hpp"
#include "io/text_io.hpp"
#include "map/raster_window.hpp"
#include "potmap/error.hpp"
#include "render/png_writer.hpp"

namespace potmap {

namespace {

constexpr std::size_t kMaxAxisCells = 1000000;  // PNG writers' (libpng's default) limit

std::size_t axis_cells(double lo, double hi, double res) {
  const double n = std::ceil((hi - lo) / res);
  return n > 0 ? static_cast<std::size_t>(n) : 0;
}

// The shortest text that reads back as the same double.
std::string num(double v) {
  return detail::format_double(v);
}

struct MinMax {
  float lo = std::numeric_limits<float>::infinity();
  float hi = -std::numeric_limits<float>::infinity();
  // The finite values of v[0..n). Written without branches (selects the compiler turns into
  // vector min/max): this runs over every cell of the window.
  void add(const float* v, std::size_t n) {
    constexpr float inf = std::numeric_limits<float>::infinity();
    float l = lo, h = hi;
#pragma omp simd reduction(min : l) reduction(max : h)
    for (std::size_t i = 0; i < n; ++i) {
      const float x = v[i];
      const bool finite = std::fabs(x) <= std::numeric_limits<float>::max();  // not NaN or inf
      const float xl = finite ? x : inf, xh = finite ? x : -inf;
      l = xl < l ? xl : l;
      h = xh > h ? xh : h;
    }
    lo = l;
    hi = h;
  }
  float min() const {
    return lo <= hi ? lo : 0.0f;
  }
  float max() const {
    return lo <= hi ? hi : 0.0f;
  }
};

// The pictures' palette and quantisation (raster.hpp): entries 0..254 are the colour map at
// k / 254, entry 255 the NaN grey.
constexpr int kLevels = 254;
constexpr std::uint8_t kNanIndex = 255;

std::vector<Rgb> palette(Colormap cm) {
  std::vector<Rgb> p(256);
  for (int k = 0; k <= kLevels; ++k) p[k] = colormap(cm, double(k) / kLevels);
  p[kNanIndex] = colormap(cm, std::nan(""));
  return p;
}

// Palette indices of n values: round(254 t) for t clamped to [0, 1], NaN to the grey entry;
// for variance t = s2 / (1 + s2) first (raster.hpp; negative variances cannot occur, +inf maps
// to 1). Branch-free, like MinMax::add, so that it vectorises.
template <bool Variance>
void palette_indices(const float* v, std::size_t n, std::uint8_t* idx) {
  constexpr float inf = std::numeric_limits<float>::infinity();
#pragma omp simd
  for (std::size_t i = 0; i < n; ++i) {
    const float x = v[i];
    const float t = Variance ? (x == inf ? 1.0f : x / (1.0f + x)) : x;
    float c = t > 0.0f ? t : 0.0f;  // NaN -> 0 here; replaced below
    c = c < 1.0f ? c : 1.0f;
    const int k = static_cast<int>(c * float(kLevels) + 0.5f);
    idx[i] = static_cast<std::uint8_t>(t == t ? k : kNanIndex);
  }
}

// The output files of one rasterize(), open while the bands are written.
struct RasterFiles {
  std::unique_ptr<detail::PngWriter> prob_png, var_png;
  std::unique_ptr<detail::NpyWriter> prob_npy, var_npy;

  RasterFiles(const std::string& out_prefix, std::size_t W, std::size_t H,
              const RasterOptions& options) {
    if (options.write_png) {
      prob_png = std::make_unique<detail::PngWriter>(out_prefix + "_prob.png", W, H,
                                                     palette(options.prob_colormap));
      var_png = std::make_unique<detail::PngWriter>(out_prefix + "_var.png", W, H,
                                                    palette(options.var_colormap));
    }
    if (options.write_npy) {
      prob_npy = std::make_unique<detail::NpyWriter>(out_prefix + "_prob.npy", H, W);
      var_npy = std::make_unique<detail::NpyWriter>(out_prefix + "_var.npy", H, W);
    }
  }

  // Puts the files in place only now that every one is complete and synced: a full disk fails
  // one of the complete() calls, before any rename, so the previous files all stay as they
  // were. Should a rename itself then fail (rare: same folder), the files already renamed by
  // this run are removed, so no mixed set of old and new is left behind. Returns the files.
  std::vector<std::string> install(const std::string& out_prefix) {
    if (prob_png) prob_png->complete();
    if (var_png) var_png->complete();
    if (prob_npy) prob_npy->complete();
    if (var_npy) var_npy->complete();
    std::vector<std::string> done;
    try {
      if (prob_png) prob_png->finish(), done.push_back(out_prefix + "_prob.png");
      if (var_png) var_png->finish(), done.push_back(out_prefix + "_var.png");
      if (prob_npy) prob_npy->finish(), done.push_back(out_prefix + "_prob.npy");
      if (var_npy) var_npy->finish(), done.push_back(out_prefix + "_var.npy");
    } catch (...) {
      for (const std::string& f : done) std::remove(f.c_str());
      throw;
    }
    return done;
  }
};

// One band's rows, top row first, to one quantity's writers; each quantity has its own index
// row so that probability and variance encode at once.
void write_rows(const float* band, std::size_t W, std::size_t rows, detail::NpyWriter* npy,
                detail::PngWriter* png, bool variance, MinMax& stat,
                std::vector<std::uint8_t>& idx) {
  idx.resize(W);
  for (std::size_t j = rows; j-- > 0;) {
    const float* v = band + j * W;
    stat.add(v, W);
    if (npy) npy->write_row(v);
    if (!png) continue;
    if (variance)
      palette_indices<true>(v, W, idx.data());
    else
      palette_indices<false>(v, W, idx.data());
    png->write_row(idx.data());
  }
}

// Evaluates the window band by band into the files; returns the number of bands.
//
// Bands run top to bottom (image order) but are cut on a lattice of whole 64-row blocks counted
// from the window's bottom; the evaluator's tiles (RasterTuning::tile: 16, 32 or 64) divide 64,
// so every band is evaluated by exactly the tiles a single pass would use: the values do not
// depend on the band size. Encoding and writing band k (two threads: probability and variance)
// overlap the evaluation of band k + 1; two sets of buffers take turns.
std::size_t write_bands(detail::WindowEvaluator& ev, const RasterSpec& spec,
                        const RasterOptions& options, RasterFiles& files, MinMax& pstat,
                        MinMax& vstat) {
  const std::size_t W = spec.width(), H = spec.height();
  const std::size_t band_rows = std::max<std::size_t>(1, options.max_band_cells / W);
  constexpr std::size_t kTileRows = 64;
  const std::size_t band = std::max<std::size_t>(kTileRows, band_rows / kTileRows * kTileRows);
  std::vector<float> var[2], prob[2];
  std::vector<std::uint8_t> idx_p, idx_v;
  std::future<void> writing_p, writing_v;
  auto wait_writers = [&] {
    // Both are waited for before either error propagates, so no thread outlives its buffers.
    std::exception_ptr err;
    for (std::future<void>* f : {&writing_p, &writing_v}) {
      if (!f->valid()) continue;
      try {
        f->get();
      } catch (...) {
        if (!err) err = std::current_exception();
      }
    }
    if (err) std::rethrow_exception(err);
  };
  std::size_t bands = 0;
  int slot = 0;
  std::size_t j_hi = H;  // rows counted from the bottom (y up): image row r is j = H - 1 - r
  try {
    while (j_hi > 0) {
      const std::size_t j_lo = (j_hi - 1) / band * band;
      const std::size_t rows = j_hi - j_lo, n = W * rows;
      var[slot].resize(n);
      prob[slot].resize(n);
      ev.rows(0, W, j_lo, rows, var[slot].data(), prob[slot].data());
      wait_writers();
      writing_p = std::async(std::launch::async, [&, rows, pr = prob[slot].data()] {
        write_rows(pr, W, rows, files.prob_npy.get(), files.prob_png.get(), false, pstat, idx_p);
      });
      writing_v = std::async(std::launch::async, [&, rows, vr = var[slot].data()] {
        write_rows(vr, W, rows, files.var_npy.get(), files.var_png.get(), true, vstat, idx_v);
      });
      slot ^= 1;
      ++bands;
      if (options.progress) options.progress(double(H - j_lo) / double(H));
      j_hi = j_lo;
    }
    wait_writers();
  } catch (...) {
    try {
      wait_writers();
    } catch (...) {
    }
    throw;
  }
  return bands;
}

}  // namespace

std::size_t RasterSpec::width() const {
  return axis_cells(xmin, xmax, resolution);
}
std::size_t RasterSpec::height() const {
  return axis_cells(ymin, ymax, resolution);
}

void RasterSpec::validate() const {
  const char* names[] = {"xmin", "xmax", "ymin", "ymax", "resolution", "z", "band_step"};
  const double values[] = {xmin, xmax, ymin, ymax, resolution, z, band_step};
  for (int i = 0; i < 7; ++i)
    if (!std::isfinite(values[i]))
      throw ArgumentError(std::string("raster: ") + names[i] + " is not finite (" + num(values[i]) +
                          ")");
  if (!(resolution > 0))
    throw ArgumentError("raster: resolution must be > 0, got " + num(resolution));
  if (!(xmin < xmax))
    throw ArgumentError("raster: xmin (" + num(xmin) + ") must be below xmax (" + num(xmax) + ")");
  if (!(ymin < ymax))
    throw ArgumentError("raster: ymin (" + num(ymin) + ") must be below ymax (" + num(ymax) + ")");
  if (has_band() && (!std::isfinite(band_lo) || !std::isfinite(band_hi)))
    throw ArgumentError("raster: height band " + num(band_lo) + ".." + num(band_hi) +
                        " m: both ends must be finite");
  if (has_band() && band_lo > band_hi)
    throw ArgumentError("raster: height band bottom " + num(band_lo) + " m is above its top " +
                        num(band_hi) + " m");
  if (band_step < 0)
    throw ArgumentError("raster: band_step must be >= 0 (0: the map's default), got " +
                        num(band_step));
  if ((xmax - xmin) / resolution > double(kMaxAxisCells) ||
      (ymax - ymin) / resolution > double(kMaxAxisCells))
    throw ArgumentError("raster: window of " + num((xmax - xmin) / resolution) + " x " +
                        num((ymax - ymin) / resolution) + " cells; at most " +
                        std::to_string(kMaxAxisCells) + " per axis");
}

RasterSummary rasterize(Context& ctx, const KernelMap& map, const RasterSpec& spec,
                        const std::string& out_prefix, const RasterOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  spec.validate();
  if (out_prefix.empty()) throw ArgumentError("raster: empty output prefix");
  detail::WindowEvaluator ev(ctx, map, spec, options.eval);  // validates the map (and band)

  RasterSummary sum;
  sum.width = spec.width();
  sum.height = spec.height();
  sum.cells = sum.width * sum.height;
  // Writers first: an unwritable folder fails before any device work.
  RasterFiles files(out_prefix, sum.width, sum.height, options);
  MinMax pstat, vstat;
  sum.bands = write_bands(ev, spec, options, files, pstat, vstat);
  sum.files = files.install(out_prefix);
  sum.levels = ev.levels().size();
  if (sum.levels > 1) sum.level_spacing = ev.levels()[1] - ev.levels()[0];
  sum.prob_min = pstat.min();
  sum.prob_max = pstat.max();
  sum.var_min = vstat.min();
  sum.var_max = vstat.max();
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return sum;
}

}  // namespace potmap
