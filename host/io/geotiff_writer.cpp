#include "io/geotiff_writer.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <memory>
#include <sstream>
#include <thread>

#include "potmap/error.hpp"

#ifdef POTMAP_WITH_GDAL
#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_string.h>
#include <cpl_vsi.h>
#include <gdal.h>
#include <ogr_srs_api.h>
#include "io/cog_tiff.hpp"
#endif

namespace potmap::detail {

#ifdef POTMAP_WITH_GDAL
namespace {

struct DatasetCloser {
  void operator()(void* h) const {
    if (h) GDALClose(static_cast<GDALDatasetH>(h));
  }
};
using Dataset = std::unique_ptr<void, DatasetCloser>;

// GDAL reports through a handler; collect the last message instead of printing it.
class QuietErrors {
 public:
  QuietErrors() {
    CPLPushErrorHandler(CPLQuietErrorHandler);
    CPLErrorReset();
  }
  ~QuietErrors() { CPLPopErrorHandler(); }
  QuietErrors(const QuietErrors&) = delete;
  QuietErrors& operator=(const QuietErrors&) = delete;
};

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  const char* msg = CPLGetLastErrorMsg();
  throw Error(path + ": " + what + (msg && *msg ? std::string(": GDAL: ") + msg : std::string()));
}

// Options as GDAL takes them: a NULL-terminated list of "KEY=VALUE".
class Options {
 public:
  Options& set(const char* key, const std::string& value) {
    list_ = CSLSetNameValue(list_, key, value.c_str());
    return *this;
  }
  char** get() const { return list_; }
  Options() = default;
  Options(const Options&) = delete;
  Options& operator=(const Options&) = delete;
  ~Options() { CSLDestroy(list_); }

 private:
  char** list_ = nullptr;
};

void register_drivers() {
  // Registration is GDAL's own process-wide table; calling it again is a no-op.
  GDALAllRegister();
}

std::string crs_wkt(const std::string& crs, const std::string& path) {
  if (crs.empty())
    return "LOCAL_CS[\"potmap map frame\",LOCAL_DATUM[\"potmap map origin\",0],"
           "UNIT[\"metre\",1,AUTHORITY[\"EPSG\",\"9001\"]],AXIS[\"X\",EAST],AXIS[\"Y\",NORTH]]";
  OGRSpatialReferenceH srs = OSRNewSpatialReference(nullptr);
  std::unique_ptr<void, void (*)(void*)> guard(
      srs, [](void* s) { OSRDestroySpatialReference(static_cast<OGRSpatialReferenceH>(s)); });
  if (OSRSetFromUserInput(srs, crs.c_str()) != OGRERR_NONE)
    throw ArgumentError(path + ": CRS '" + crs + "' is not one GDAL reads (EPSG:n, WKT, PROJ)");
  char* wkt = nullptr;
  if (OSRExportToWkt(srs, &wkt) != OGRERR_NONE || !wkt)
    fail(path, "cannot export CRS '" + crs + "'");
  std::string out = wkt;
  CPLFree(wkt);
  return out;
}

// Every file of a write lies next to `path`: its folder is made here when it does not exist yet
// (as AtomicFile makes it for the library's other writers).
std::string temp_name(const std::string& path, const char* what) {
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  return path + "." + what + "-" + std::to_string(::getpid()) + ".tif";
}

struct RemoveOnExit {
  std::string path;
  ~RemoveOnExit() {
    std::error_code ec;
    std::filesystem::remove(path, ec);
  }
};

// fsync before the rename, as AtomicFile does: a crash must not leave the final name on a file
// whose blocks never reached the disk.
void sync_file(const std::string& path, const std::string& file) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(path + ": cannot reopen " + file + ": " + std::strerror(errno));
  const bool ok = ::fsync(fd) == 0 || errno == EINVAL;
  const std::string why = ok ? "" : std::strerror(errno);
  ::close(fd);
  if (!ok) throw Error(path + ": cannot write " + file + ": " + why);
}

// GDAL's block cache is process-wide and defaults to 5 % of the machine's memory: with room
// for most of the image, the blocks written stay allocated until the end and the job spends
// more time in page faults and freeing than in copying (docs/raster-scale.md: the 0.05 m COG
// step took 2.5x as long). A small cache keeps memory bounded by the tile size, as the job
// promises. The user's GDAL_CACHEMAX wins; the previous size is restored on return, for
// embedders that use GDAL themselves.
class BoundedBlockCache {
 public:
  BoundedBlockCache() : old_(GDALGetCacheMax64()) {
    if (!CPLGetConfigOption("GDAL_CACHEMAX", nullptr)) GDALSetCacheMax64(kBytes);
  }
  ~BoundedBlockCache() { GDALSetCacheMax64(old_); }
  BoundedBlockCache(const BoundedBlockCache&) = delete;
  BoundedBlockCache& operator=(const BoundedBlockCache&) = delete;

 private:
  static constexpr GIntBig kBytes = GIntBig(32) << 20;  // 16 blocks of 512 x 512 float32
  GIntBig old_;
};

// The staging GTiff, empty: tiled, uncompressed, georeferenced, its bands named. In memory
// (GDAL's MEM driver, `staging` then only names it in errors) when `in_memory`.
Dataset create_staging(const std::string& path, const GeoTiffSpec& spec, const std::string& staging,
                       const std::string& wkt, bool in_memory = false) {
  GDALDriverH driver = GDALGetDriverByName(in_memory ? "MEM" : "GTiff");
  Options o;
  if (!in_memory)
    o.set("TILED", "YES")
        .set("BLOCKXSIZE", std::to_string(spec.block))
        .set("BLOCKYSIZE", std::to_string(spec.block))
        .set("COMPRESS", "NONE")
        .set("INTERLEAVE", "BAND")
        .set("BIGTIFF", "IF_SAFER");
  const int nb = static_cast<int>(spec.band_names.size());
  Dataset ds(GDALCreate(driver, in_memory ? "" : staging.c_str(), static_cast<int>(spec.width),
                        static_cast<int>(spec.height), nb, GDT_Float32, o.get()));
  if (!ds)
    fail(path,
         "cannot create the staging " + std::string(in_memory ? "image " : "file ") + staging);
  double gt[6] = {spec.left, spec.pixel, 0, spec.top, 0, -spec.pixel};
  GDALSetGeoTransform(ds.get(), gt);
  GDALSetProjection(ds.get(), wkt.c_str());
  for (const auto& [k, v] : spec.metadata)
    GDALSetMetadataItem(ds.get(), k.c_str(), v.c_str(), nullptr);
  for (int b = 0; b < nb; ++b) {
    GDALRasterBandH band = GDALGetRasterBand(ds.get(), b + 1);
    GDALSetDescription(band, spec.band_names[b].c_str());
    GDALSetRasterNoDataValue(band, std::nan(""));
  }
  return ds;
}

// The overviews live in the uncompressed staging file, where the COG driver takes them as they
// are (OVERVIEWS=AUTO); left to it, it would compute them into a compressed temporary file of
// its own and compress them again into the COG. Levels as the COG driver picks them: halve
// until both sides fit in one block. Their directories are made first, empty ("NONE"), so that
// the first level is written from each block while it is in memory rather than read back from
// the whole image (0.8 s of a 5.5 s job at 64 M cells). Returns the levels' factors.
std::vector<int> add_empty_overviews(GDALDatasetH ds, const std::string& path,
                                     const GeoTiffSpec& spec, const std::string& staging) {
  std::vector<int> factors;
  for (int f = 2; spec.overviews; f *= 2) {
    factors.push_back(f);
    if ((spec.width + f - 1) / f <= spec.block && (spec.height + f - 1) / f <= spec.block) break;
  }
  if (spec.width <= spec.block && spec.height <= spec.block) factors.clear();
  if (!factors.empty() &&
      GDALBuildOverviews(ds, "NONE", static_cast<int>(factors.size()), factors.data(), 0, nullptr,
                         nullptr, nullptr) != CE_None)
    fail(path, "making the overviews of " + staging);
  return factors;
}

// Every block of every band from fill(), with its first overview level when there are
// overviews.
void write_staging_blocks(GDALDatasetH ds, const std::string& path, const GeoTiffSpec& spec,
                          const std::string& staging, const BlockFill& fill, bool overviews,
                          const std::function<void(double)>& progress) {
  const int nb = static_cast<int>(spec.band_names.size());
  std::vector<std::vector<float>> buf(nb, std::vector<float>(spec.block * spec.block));
  std::vector<float> half((spec.block / 2) * (spec.block / 2));
  std::vector<float*> ptr(nb);
  const std::size_t bx = (spec.width + spec.block - 1) / spec.block;
  const std::size_t by = (spec.height + spec.block - 1) / spec.block;
  for (std::size_t r = 0; r < by; ++r)
    for (std::size_t c = 0; c < bx; ++c) {
      const std::size_t x0 = c * spec.block, y0 = r * spec.block;
      const std::size_t w = std::min(spec.block, spec.width - x0);
      const std::size_t h = std::min(spec.block, spec.height - y0);
      for (int b = 0; b < nb; ++b) ptr[b] = buf[b].data();
      fill(x0, y0, w, h, ptr);
      for (int b = 0; b < nb; ++b) {
        GDALRasterBandH band = GDALGetRasterBand(ds, b + 1);
        if (GDALRasterIO(band, GF_Write, int(x0), int(y0), int(w), int(h), ptr[b], int(w), int(h),
                         GDT_Float32, 0, 0) != CE_None)
          fail(path, "writing block at pixel (" + std::to_string(x0) + ", " + std::to_string(y0) +
                         ") of " + staging);
        if (!overviews) continue;
        const std::size_t hw = (w + 1) / 2, hh = (h + 1) / 2;
        average_halves(ptr[b], w, h, half.data());
        if (GDALRasterIO(GDALGetOverview(band, 0), GF_Write, int(x0 / 2), int(y0 / 2), int(hw),
                         int(hh), half.data(), int(hw), int(hh), GDT_Float32, 0, 0) != CE_None)
          fail(path, "writing the overview of the block at pixel (" + std::to_string(x0) + ", " +
                         std::to_string(y0) + ") of " + staging);
      }
      if (progress) progress(0.6 * double(r * bx + c + 1) / double(bx * by));
    }
}

// The coarser levels from the first (a quarter of the image), each averaged over its cells:
// the overviews of `ds` but the first from its first (`first`: 0.6 to 0.7 of the progress),
// or all of them from its bands (`first` -1: the bands are the first level; 0.3 to 0.4).
void regenerate_coarser_overviews(GDALDatasetH ds, const std::string& path, int bands,
                                  const std::string& staging,
                                  const std::function<void(double)>& progress, int first = 0) {
  struct Ctx {
    const std::function<void(double)>* progress;
    int band, bands;
    double start;
  } pctx{&progress, 0, bands, first < 0 ? 0.3 : 0.6};
  GDALProgressFunc pf = [](double f, const char*, void* arg) -> int {
    auto* c = static_cast<Ctx*>(arg);
    if (*c->progress) (*c->progress)(c->start + 0.1 * (c->band + f) / c->bands);
    return TRUE;
  };
  for (int b = 0; b < bands; ++b) {
    pctx.band = b;
    GDALRasterBandH band = GDALGetRasterBand(ds, b + 1);
    std::vector<GDALRasterBandH> coarser;
    for (int i = first + 1; i < GDALGetOverviewCount(band); ++i)
      coarser.push_back(GDALGetOverview(band, i));
    GDALRasterBandH from = first < 0 ? band : GDALGetOverview(band, first);
    if (GDALRegenerateOverviews(from, static_cast<int>(coarser.size()), coarser.data(), "AVERAGE",
                                pf, &pctx) != CE_None)
      fail(path, "computing the overviews in " + staging);
  }
}

// Stage: a tiled GTiff written block by block, uncompressed: it is read once, right away (from
// the page cache, as a rule), and float32 maps barely compress, so DEFLATE here would cost a
// whole pass of compression for little disk. It takes 4 bytes a cell and band on disk until
// the COG is written.
void write_staging(const std::string& path, const GeoTiffSpec& spec, const std::string& staging,
                   const std::string& wkt, const BlockFill& fill,
                   const std::function<void(double)>& progress) {
  Dataset ds = create_staging(path, spec, staging, wkt);
  const std::vector<int> factors = add_empty_overviews(ds.get(), path, spec, staging);
  write_staging_blocks(ds.get(), path, spec, staging, fill, !factors.empty(), progress);
  if (factors.size() > 1)
    regenerate_coarser_overviews(ds.get(), path, static_cast<int>(spec.band_names.size()), staging,
                                 progress);
  GDALFlushCache(ds.get());
  ds.reset();  // closing writes the last blocks: its failure must show below too
  if (CPLGetLastErrorType() >= CE_Failure) fail(path, "writing " + staging);
}

// The COG layout: overviews and blocks in the order readers expect. The spec's level
// (default_level()) with the floating-point predictor: float32 maps are mostly mantissa noise
// to a compressor without it, and higher levels buy a few per cent of size for several times
// the time (docs/raster-scale.md). Blocks are compressed on every core; GDAL writes them in order,
// so the file is the same for the same input whatever the thread count (no time stamp either).
void write_cog_copy(const std::string& path, const GeoTiffSpec& spec, const std::string& staging,
                    const std::string& final_temp, const std::function<void(double)>& progress) {
  GDALDriverH cog = GDALGetDriverByName("COG");
  Dataset src(GDALOpen(staging.c_str(), GA_ReadOnly));
  if (!src) fail(path, "cannot reopen " + staging);
  const std::string& compression = spec.compression;
  Options o;
  o.set("BLOCKSIZE", std::to_string(spec.block))
      .set("COMPRESS", compression)
      .set("NUM_THREADS", "ALL_CPUS")
      .set("OVERVIEWS", spec.overviews ? "AUTO" : "NONE")
      .set("RESAMPLING", "AVERAGE")
      .set("BIGTIFF", "IF_SAFER");
  if (compression == "ZSTD" || compression == "DEFLATE")
    o.set("LEVEL", std::to_string(default_level(compression, spec.level)));
  if (compression != "NONE") o.set("PREDICTOR", "YES");
  struct Ctx {
    const std::function<void(double)>* progress;
  } pctx{&progress};
  GDALProgressFunc pf = [](double f, const char*, void* arg) -> int {
    auto* c = static_cast<Ctx*>(arg);
    if (*c->progress) (*c->progress)(0.7 + 0.3 * f);
    return TRUE;
  };
  CPLErrorReset();
  Dataset out(GDALCreateCopy(cog, final_temp.c_str(), src.get(), FALSE, o.get(), pf, &pctx));
  if (!out) fail(path, "the COG driver could not write " + final_temp);
  GDALFlushCache(out.get());
  // GDAL 3.6's GDALClose returns nothing: a write that fails while closing (the last blocks,
  // the directory) shows only as the last error.
  out.reset();
  if (CPLGetLastErrorType() >= CE_Failure) fail(path, "writing " + final_temp);
}

void check_spec(const std::string& path, const GeoTiffSpec& spec) {
  const int nb = static_cast<int>(spec.band_names.size());
  if (nb < 1 || spec.width == 0 || spec.height == 0 || spec.block == 0 || spec.block % 16)
    throw ArgumentError(path + ": GeoTIFF of " + std::to_string(spec.width) + " x " +
                        std::to_string(spec.height) + " pixels, " + std::to_string(nb) +
                        " bands, block " + std::to_string(spec.block) +
                        ": needs pixels, a band and a block that is a multiple of 16");
  check_compression(spec.compression, path);
  check_level(spec.compression, spec.level, path);
  if (!GDALGetDriverByName("GTiff") || !GDALGetDriverByName("COG"))
    fail(path, "GDAL lacks the GTiff or COG driver");
}

// --- write_cog_encoded ------------------------------------------------------------------------

// The output of write_cog_encoded(), written at known offsets under a temporary name: removed
// unless finish() put it in place.
class CogFile {
 public:
  CogFile(const std::string& path, std::string file) : path_(path), file_(std::move(file)) {
    fd_ = ::open(file_.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd_ < 0) throw Error(path_ + ": cannot create " + file_ + ": " + std::strerror(errno));
  }
  ~CogFile() {
    if (fd_ >= 0) ::close(fd_);
    if (!kept_) ::unlink(file_.c_str());
  }
  CogFile(const CogFile&) = delete;
  CogFile& operator=(const CogFile&) = delete;

  std::uint64_t pos() const { return pos_; }
  void seek(std::uint64_t at) { pos_ = at; }
  void write(const char* data, std::size_t n) {
    for (std::size_t done = 0; done < n;) {
      const ssize_t k = ::pwrite(fd_, data + done, n - done, off_t(pos_ + done));
      if (k < 0 && errno == EINTR) continue;
      if (k <= 0) throw Error(path_ + ": cannot write " + file_ + ": " + std::strerror(errno));
      done += std::size_t(k);
    }
    pos_ += n;
    hand_over();
  }
  // `n` bytes of `from` at `offset`, in the kernel where it can.
  void copy(const std::string& from, std::uint64_t offset, std::uint64_t n) {
    const int in = ::open(from.c_str(), O_RDONLY | O_CLOEXEC);
    if (in < 0) throw Error(path_ + ": cannot open " + from + ": " + std::strerror(errno));
    std::unique_ptr<int, void (*)(int*)> closer(new int(in), [](int* f) {
      ::close(*f);
      delete f;
    });
    loff_t src = loff_t(offset), dst = loff_t(pos_);
    for (std::uint64_t left = n; left > 0;) {
      ssize_t k = ::copy_file_range(in, &src, fd_, &dst, std::size_t(left), 0);
      if (k < 0 && errno == EINTR) continue;
      if (k < 0 && (errno == EXDEV || errno == ENOSYS || errno == EINVAL || errno == EOPNOTSUPP)) {
        std::string buf(std::size_t(left), '\0');  // no in-kernel copy here: through memory
        k = ::pread(in, buf.data(), buf.size(), off_t(src));
        if (k > 0) {
          const std::uint64_t keep = pos_;
          pos_ = std::uint64_t(dst);
          write(buf.data(), std::size_t(k));
          pos_ = keep;
          src += k;
          dst += k;
        }
      }
      if (k <= 0)
        throw Error(path_ + ": cannot copy " + std::to_string(n) + " bytes at offset " +
                    std::to_string(offset) + " of " + from + " into " + file_ +
                    (k < 0 ? std::string(": ") + std::strerror(errno) : ": the file is shorter"));
      left -= std::uint64_t(k);
    }
    pos_ += n;
    hand_over();
  }
  // Syncs the file and renames it to the output.
  void finish() {
    if (::fsync(fd_) != 0 && errno != EINVAL)
      throw Error(path_ + ": cannot write " + file_ + ": " + std::strerror(errno));
    std::error_code ec;
    std::filesystem::rename(file_, path_, ec);
    if (ec) throw Error(path_ + ": cannot rename " + file_ + " into place: " + ec.message());
    kept_ = true;
  }

 private:
  // Starts writing out each 8 MiB written past the last handed over (the file is written front
  // to back but for its header), so that finish()'s fsync waits for the tail only, not for the
  // whole file (about 0.2 s of a 64 M-cell job). A hint: a failure shows at the fsync.
  void hand_over() {
#ifdef __linux__
    if (pos_ > handed_over_ + (std::uint64_t(8) << 20)) {
      ::sync_file_range(fd_, off64_t(handed_over_), off64_t(pos_ - handed_over_),
                        SYNC_FILE_RANGE_WRITE);
      handed_over_ = pos_;
    }
#endif
  }

  std::string path_, file_;
  int fd_ = -1;
  std::uint64_t pos_ = 0, handed_over_ = 0;
  bool kept_ = false;
};

// A block in the COG: its size (4 bytes), its bytes, its last 4 bytes again (GDAL's leader and
// trailer, which let a reader check that it read a whole block). Returns where its bytes start.
std::uint64_t put_block(CogFile& out, const std::string& bytes) {
  std::string b;
  b.reserve(bytes.size() + 8);
  for (int i = 0; i < 4; ++i) b.push_back(char((bytes.size() >> (8 * i)) & 0xff));
  b += bytes;
  b += bytes.substr(bytes.size() < 4 ? 0 : bytes.size() - 4);
  out.write(b.data(), b.size());
  return out.pos() - bytes.size() - std::min<std::size_t>(4, bytes.size());
}

std::uint64_t copy_block(CogFile& out, const std::string& path, const EncodedBlock& b) {
  std::string leader, trailer(std::size_t(std::min<std::uint64_t>(4, b.size)), '\0');
  for (int i = 0; i < 4; ++i) leader.push_back(char((b.size >> (8 * i)) & 0xff));
  {
    std::ifstream in(b.file, std::ios::binary);
    in.seekg(std::streamoff(b.offset + b.size - trailer.size()));
    if (!in.read(trailer.data(), std::streamsize(trailer.size())))
      throw Error(path + ": cannot read the block of " + std::to_string(b.size) + " bytes at " +
                  std::to_string(b.offset) + " of " + b.file);
  }
  out.write(leader.data(), 4);
  const std::uint64_t at = out.pos();
  out.copy(b.file, b.offset, b.size);
  out.write(trailer.data(), trailer.size());
  return at;
}

// GDAL's fields of this spec (georeferencing, metadata, band names, nodata): those of a small
// GTiff that GDAL writes in memory with the same settings, as it writes them into a COG.
std::vector<TiffField> gdal_own_fields(const std::string& path, const GeoTiffSpec& spec,
                                       const std::string& wkt) {
  static std::atomic<int> serial{0};
  const std::string mem = "/vsimem/potmap-cog-fields-" + std::to_string(::getpid()) + "-" +
                          std::to_string(serial++) + ".tif";
  GeoTiffSpec small = spec;
  small.width = small.height = small.block = 16;
  create_staging(path, small, mem, wkt).reset();
  vsi_l_offset len = 0;
  GByte* buf = VSIGetMemFileBuffer(mem.c_str(), &len, FALSE);
  const std::string tiff = buf ? std::string(reinterpret_cast<const char*>(buf), len) : "";
  VSIUnlink(mem.c_str());
  if (tiff.empty()) fail(path, "GDAL wrote no GeoTIFF fields");
  return gdal_fields(path, tiff);
}

// The levels of the COG, full resolution first: halving as write_cog() does (until both sides
// fit in one block), each with room for its blocks' offsets and sizes.
std::vector<CogLevel> cog_levels(const GeoTiffSpec& spec) {
  std::vector<CogLevel> levels(1);
  levels[0].width = spec.width;
  levels[0].height = spec.height;
  const bool small = spec.width <= spec.block && spec.height <= spec.block;
  for (std::size_t f = 2; spec.overviews && !small; f *= 2) {
    levels.push_back({(spec.width + f - 1) / f, (spec.height + f - 1) / f, {}, {}});
    if (levels.back().width <= spec.block && levels.back().height <= spec.block) break;
  }
  for (CogLevel& l : levels) {
    const std::size_t n =
        ((l.width + spec.block - 1) / spec.block) * ((l.height + spec.block - 1) / spec.block);
    l.offsets.assign(n, 0);
    l.sizes.assign(n, 0);
  }
  return levels;
}

// Overview `from + 1` of every band of `ds` from its source (the band for `from` -1, else
// overview `from`) when both of the source's sides are even, each cell the average of the
// 2 x 2 below it (average_halves()); false, and nothing done, when a side is odd.
bool halve_exactly(GDALDatasetH ds, const std::string& path, int bands, int from) {
  std::vector<float> in, out;
  for (int b = 0; b < bands; ++b) {
    GDALRasterBandH band = GDALGetRasterBand(ds, b + 1);
    GDALRasterBandH src = from < 0 ? band : GDALGetOverview(band, from);
    GDALRasterBandH dst = GDALGetOverview(band, from + 1);
    const int w = GDALGetRasterBandXSize(src), h = GDALGetRasterBandYSize(src);
    if (w % 2 || h % 2 || GDALGetRasterBandXSize(dst) != w / 2 ||
        GDALGetRasterBandYSize(dst) != h / 2)
      return false;
    in.resize(std::size_t(w) * std::size_t(h));
    out.resize(in.size() / 4);
    if (GDALRasterIO(src, GF_Read, 0, 0, w, h, in.data(), w, h, GDT_Float32, 0, 0) != CE_None)
      fail(path, "reading overview level " + std::to_string(from + 1) + " in memory");
    average_halves(in.data(), std::size_t(w), std::size_t(h), out.data());
    if (GDALRasterIO(dst, GF_Write, 0, 0, w / 2, h / 2, out.data(), w / 2, h / 2, GDT_Float32, 0,
                     0) != CE_None)
      fail(path, "writing overview level " + std::to_string(from + 2) + " in memory");
  }
  return true;
}

// Where the full-resolution blocks' bytes are, and the overviews: the first level as the
// staging image's bands, the coarser ones as its overviews (null without overviews).
struct Staged {
  std::vector<EncodedBlock> blocks;
  Dataset overviews;
};

// Takes every full-resolution block from `source`, its first overview level into the staging
// image (uncompressed; the coarser levels its overviews, computed from it by GDAL, as
// write_cog() computes them). The image is held in memory when its levels fit
// spec.overview_memory (no file to write and read back, and GDAL's block cache out of the way),
// else in the GTiff `staging`.
Staged stage_overviews(const std::string& path, const GeoTiffSpec& spec, const std::string& staging,
                       const std::string& wkt, bool overviews, const EncodedBlockSource& source,
                       const std::function<void(double)>& progress) {
  const std::size_t B = spec.block, nb = spec.band_names.size();
  const std::size_t bx = (spec.width + B - 1) / B, by = (spec.height + B - 1) / B;
  std::vector<std::vector<float>> half(overviews ? nb : 0, std::vector<float>((B / 2) * (B / 2)));
  std::vector<float*> ptr;
  for (auto& h : half) ptr.push_back(h.data());
  Dataset ds;
  bool in_memory = false;
  if (overviews) {
    GeoTiffSpec first = spec;
    first.width = (spec.width + 1) / 2;
    first.height = (spec.height + 1) / 2;
    // The first level and the coarser ones (a third of it), float32 bands.
    const double bytes = 4.0 * 4.0 / 3.0 * double(first.width) * double(first.height) * double(nb);
    in_memory = bytes <= double(spec.overview_memory);
    ds = create_staging(path, first, staging, wkt, in_memory);
    add_empty_overviews(ds.get(), path, first, staging);
  }
  std::vector<EncodedBlock> blocks;
  for (std::size_t r = 0; r < by; ++r)
    for (std::size_t c = 0; c < bx; ++c) {
      blocks.push_back(source(r, c, ptr));
      const std::size_t x0 = c * B, y0 = r * B;
      const int hw = int((std::min(B, spec.width - x0) + 1) / 2);
      const int hh = int((std::min(B, spec.height - y0) + 1) / 2);
      for (std::size_t b = 0; b < half.size(); ++b)
        if (GDALRasterIO(GDALGetRasterBand(ds.get(), int(b) + 1), GF_Write, int(x0 / 2),
                         int(y0 / 2), hw, hh, ptr[b], hw, hh, GDT_Float32, 0, 0) != CE_None)
          fail(path, "writing the overview of the block at pixel (" + std::to_string(x0) + ", " +
                         std::to_string(y0) + ") of " + staging);
      if (progress) progress(0.3 * double(blocks.size()) / double(bx * by));
    }
  if (!overviews) return {std::move(blocks), nullptr};
  // In memory, the levels whose source has even sides are halved here (GDAL's ratio is exactly
  // 2 there, its average the 2 x 2 one, and its general resampler takes several times as
  // long); GDAL computes the levels from the first source with an odd side on.
  const int count = GDALGetOverviewCount(GDALGetRasterBand(ds.get(), 1));
  int from = -1;  // the level the rest are computed from: -1 the bands, k overview k
  while (in_memory && from + 1 < count && halve_exactly(ds.get(), path, int(nb), from)) ++from;
  if (from + 1 < count)
    regenerate_coarser_overviews(ds.get(), path, int(nb), staging, progress, from);
  GDALFlushCache(ds.get());
  if (CPLGetLastErrorType() >= CE_Failure) fail(path, "writing " + staging);
  return {std::move(blocks), std::move(ds)};
}

// Compresses overview level `k` (>= 1) from the staging file's bands (level 1) or their
// overviews, a batch of blocks at a time on every core, into `out` in row-major order.
void put_level(const std::string& path, const GeoTiffSpec& spec, GDALDatasetH staging,
               std::size_t k, CogLevel& level, CogFile& out) {
  const std::size_t B = spec.block, nb = spec.band_names.size();
  const std::size_t bx = (level.width + B - 1) / B, n = level.offsets.size();
  const std::size_t batch = std::max(2u, std::thread::hardware_concurrency());
  std::vector<std::vector<std::vector<float>>> buf(
      batch, std::vector<std::vector<float>>(nb, std::vector<float>(B * B)));
  for (std::size_t first = 0; first < n; first += batch) {
    std::vector<std::future<std::string>> encoded;
    for (std::size_t j = first; j < std::min(n, first + batch); ++j) {
      const std::size_t x0 = (j % bx) * B, y0 = (j / bx) * B;
      const std::size_t w = std::min(B, level.width - x0), h = std::min(B, level.height - y0);
      std::vector<const float*> bands;
      for (std::size_t b = 0; b < nb; ++b) {
        GDALRasterBandH band = GDALGetRasterBand(staging, int(b) + 1);
        if (k > 1) band = GDALGetOverview(band, int(k) - 2);
        float* dst = buf[j - first][b].data();
        if (GDALRasterIO(band, GF_Read, int(x0), int(y0), int(w), int(h), dst, int(w), int(h),
                         GDT_Float32, 0, 0) != CE_None)
          fail(path, "reading overview " + std::to_string(k) + " of the staging file");
        bands.push_back(dst);
      }
      encoded.push_back(std::async(std::launch::async, [&path, &spec, bands, w, h] {
        return encode_block(path, spec, bands, w, h);
      }));
    }
    for (std::size_t j = first; j < std::min(n, first + batch); ++j) {
      const std::string bytes = encoded[j - first].get();
      level.offsets[j] = put_block(out, bytes);
      level.sizes[j] = bytes.size();
    }
  }
}

}  // namespace

void write_cog_encoded(const std::string& path, const GeoTiffSpec& spec,
                       const EncodedBlockSource& source,
                       const std::function<void(double)>& progress) {
  register_drivers();
  QuietErrors quiet;
  BoundedBlockCache cache;
  check_spec(path, spec);
  const std::string wkt = crs_wkt(spec.crs, path);
  CogFields fields;
  fields.spec = &spec;
  fields.main = gdal_own_fields(path, spec, wkt);
  for (const TiffField& f : fields.main)
    if (f.tag == 42113) fields.every.push_back(f);  // GDAL_NODATA
  std::vector<CogLevel> levels = cog_levels(spec);
  double uncompressed = 0;  // GDAL's BIGTIFF=IF_SAFER: BigTIFF past 2 GB of float32
  for (const CogLevel& l : levels)
    uncompressed += 4.0 * double(l.width) * double(l.height) * double(spec.band_names.size());
  fields.bigtiff = uncompressed > 2e9;

  const std::string staging = temp_name(path, "overviews");
  RemoveOnExit remove_staging{staging};
  const Staged staged =
      stage_overviews(path, spec, staging, wkt, levels.size() > 1, source, progress);
  const std::vector<EncodedBlock>& blocks = staged.blocks;
  CogFile out(path, temp_name(path, "partial"));
  out.seek(cog_header(fields, levels).size());
  if (levels.size() > 1) {
    for (std::size_t k = levels.size() - 1; k >= 1; --k) {
      put_level(path, spec, staged.overviews.get(), k, levels[k], out);
      if (progress) progress(0.4 + 0.2 * double(levels.size() - k) / double(levels.size() - 1));
    }
  }
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    levels[0].offsets[i] = copy_block(out, path, blocks[i]);
    levels[0].sizes[i] = blocks[i].size;
    if (progress) progress(0.6 + 0.4 * double(i + 1) / double(blocks.size()));
  }
  if (!fields.bigtiff && out.pos() > 0xffffffffULL)
    throw Error(path + ": " + std::to_string(out.pos()) +
                " bytes do not fit a classic TIFF (the BigTIFF rule guessed wrong)");
  const std::string header = cog_header(fields, levels);
  out.seek(0);
  out.write(header.data(), header.size());
  out.finish();
}

void write_cog(const std::string& path, const GeoTiffSpec& spec, const BlockFill& fill,
               const std::function<void(double)>& progress) {
  register_drivers();
  QuietErrors quiet;
  BoundedBlockCache cache;
  check_spec(path, spec);
  const std::string wkt = crs_wkt(spec.crs, path);

  const std::string staging = temp_name(path, "staging");
  RemoveOnExit remove_staging{staging};
  write_staging(path, spec, staging, wkt, fill, progress);
  const std::string final_temp = temp_name(path, "partial");
  RemoveOnExit remove_partial{final_temp};
  write_cog_copy(path, spec, staging, final_temp, progress);
  sync_file(path, final_temp);
  std::error_code ec;
  std::filesystem::rename(final_temp, path, ec);
  if (ec) throw Error(path + ": cannot rename " + final_temp + " into place: " + ec.message());
}

GeoTiffImage read_geotiff_band(const std::string& path, int band) {
  register_drivers();
  QuietErrors quiet;
  Dataset ds(GDALOpen(path.c_str(), GA_ReadOnly));
  if (!ds) fail(path, "cannot open as a raster");
  GeoTiffImage im;
  im.width = GDALGetRasterXSize(ds.get());
  im.height = GDALGetRasterYSize(ds.get());
  im.bands = GDALGetRasterCount(ds.get());
  if (band < 1 || band > int(im.bands))
    throw InputError(path + ": band " + std::to_string(band) + " of " + std::to_string(im.bands));
  GDALGetGeoTransform(ds.get(), im.geotransform);
  if (const char* w = GDALGetProjectionRef(ds.get())) im.crs_wkt = w;
  if (const char* c = GDALGetMetadataItem(ds.get(), "COMPRESSION", "IMAGE_STRUCTURE"))
    im.compression = c;
  if (const char* l = GDALGetMetadataItem(ds.get(), "LAYOUT", "IMAGE_STRUCTURE")) im.layout = l;
  GDALRasterBandH b = GDALGetRasterBand(ds.get(), band);
  int bx = 0, by = 0;
  GDALGetBlockSize(b, &bx, &by);
  im.block_x = bx;
  im.block_y = by;
  im.overviews = GDALGetOverviewCount(b);
  im.values.resize(im.width * im.height);
  if (GDALRasterIO(b, GF_Read, 0, 0, int(im.width), int(im.height), im.values.data(), int(im.width),
                   int(im.height), GDT_Float32, 0, 0) != CE_None)
    fail(path, "reading band " + std::to_string(band));
  if (im.overviews > 0) {
    GDALRasterBandH o = GDALGetOverview(b, 0);
    im.overview_width = GDALGetRasterBandXSize(o);
    im.overview_height = GDALGetRasterBandYSize(o);
    im.overview_values.resize(im.overview_width * im.overview_height);
    if (GDALRasterIO(o, GF_Read, 0, 0, int(im.overview_width), int(im.overview_height),
                     im.overview_values.data(), int(im.overview_width), int(im.overview_height),
                     GDT_Float32, 0, 0) != CE_None)
      fail(path, "reading the first overview of band " + std::to_string(band));
  }
  return im;
}

void check_crs(const std::string& crs, const std::string& path) {
  register_drivers();
  QuietErrors quiet;
  crs_wkt(crs, path);
}

bool geotiff_available() {
  return true;
}

#ifdef POTMAP_GDAL_MODULE
// The module's entry points, found by name by geotiff_module.cpp (libpotmap's loader). C++
// objects by pointer: both sides are this build; potmap::Error comes from libpotmap.
extern "C" __attribute__((visibility("default"))) void potmap_gdal_write_cog(
    const std::string* path, const GeoTiffSpec* spec, const BlockFill* fill,
    const std::function<void(double)>* progress) {
  write_cog(*path, *spec, *fill, *progress);
}
extern "C" __attribute__((visibility("default"))) void potmap_gdal_write_cog_encoded(
    const std::string* path, const GeoTiffSpec* spec, const EncodedBlockSource* source,
    const std::function<void(double)>* progress) {
  write_cog_encoded(*path, *spec, *source, *progress);
}
extern "C" __attribute__((visibility("default"))) void potmap_gdal_encode_block(
    const std::string* path, const GeoTiffSpec* spec, const std::vector<const float*>* bands,
    std::size_t width, std::size_t height, std::string* out) {
  *out = encode_block(*path, *spec, *bands, width, height);
}
extern "C" __attribute__((visibility("default"))) void potmap_gdal_decode_block(
    const std::string* path, const GeoTiffSpec* spec, const std::string* bytes, std::size_t width,
    std::size_t height, const std::vector<float*>* bands) {
  decode_block(*path, *spec, *bytes, width, height, *bands);
}
extern "C" __attribute__((visibility("default"))) void potmap_gdal_read_geotiff_band(
    const std::string* path, int band, GeoTiffImage* out) {
  *out = read_geotiff_band(*path, band);
}
extern "C" __attribute__((visibility("default"))) void potmap_gdal_check_crs(
    const std::string* crs, const std::string* path) {
  check_crs(*crs, *path);
}
#endif

#else  // no GDAL in this build

void write_cog(const std::string& path, const GeoTiffSpec&, const BlockFill&,
               const std::function<void(double)>&) {
  throw Error(path +
              ": this potmap was built without GDAL, so it cannot write GeoTIFFs "
              "(install libgdal-dev and configure again)");
}
void write_cog_encoded(const std::string& path, const GeoTiffSpec&, const EncodedBlockSource&,
                       const std::function<void(double)>&) {
  write_cog(path, {}, {}, {});
}
std::string encode_block(const std::string& path, const GeoTiffSpec&,
                         const std::vector<const float*>&, std::size_t, std::size_t) {
  write_cog(path, {}, {}, {});
  return {};
}
void decode_block(const std::string& path, const GeoTiffSpec&, const std::string&, std::size_t,
                  std::size_t, const std::vector<float*>&) {
  read_geotiff_band(path, 1);
}
GeoTiffImage read_geotiff_band(const std::string& path, int) {
  throw Error(path + ": this potmap was built without GDAL, so it cannot read GeoTIFFs");
}
void check_crs(const std::string&, const std::string&) {}
bool geotiff_available() {
  return false;
}

#endif

}  // namespace potmap::detail
