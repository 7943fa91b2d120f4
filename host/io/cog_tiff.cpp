// Blocks compressed as libtiff compresses them for GDAL, and the COG's directories laid out as
// GDAL's COG driver lays them out (cog_tiff.hpp). Part of the GDAL module.
#include "io/cog_tiff.hpp"

#ifdef POTMAP_WITH_GDAL
#include <tiffio.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <memory>

#include "io/le_bytes.hpp"
#include "potmap/error.hpp"

namespace potmap::detail {

namespace {

// --- blocks -----------------------------------------------------------------------------------

// A TIFF held in memory, for libtiff's client I/O.
struct MemoryTiff {
  std::string data;
  std::uint64_t pos = 0;
  std::string error;  // libtiff's last error message
};

tmsize_t mem_read(thandle_t h, void* buf, tmsize_t n) {
  auto* m = static_cast<MemoryTiff*>(h);
  const std::uint64_t left = m->pos < m->data.size() ? m->data.size() - m->pos : 0;
  const std::size_t k = std::size_t(std::min<std::uint64_t>(left, std::uint64_t(n)));
  std::memcpy(buf, m->data.data() + m->pos, k);
  m->pos += k;
  return tmsize_t(k);
}
tmsize_t mem_write(thandle_t h, void* buf, tmsize_t n) {
  auto* m = static_cast<MemoryTiff*>(h);
  if (m->data.size() < m->pos + std::uint64_t(n)) m->data.resize(m->pos + n);
  std::memcpy(m->data.data() + m->pos, buf, std::size_t(n));
  m->pos += n;
  return n;
}
toff_t mem_seek(thandle_t h, toff_t off, int whence) {
  auto* m = static_cast<MemoryTiff*>(h);
  m->pos = whence == SEEK_SET ? off : whence == SEEK_CUR ? m->pos + off : m->data.size() + off;
  return m->pos;
}
int mem_close(thandle_t) {
  return 0;
}
toff_t mem_size(thandle_t h) {
  return static_cast<MemoryTiff*>(h)->data.size();
}
int mem_map(thandle_t, void**, toff_t*) {
  return 0;
}
void mem_unmap(thandle_t, void*, toff_t) {}

int keep_error(TIFF*, void* user, const char* module, const char* fmt, va_list ap) {
  char text[512];
  std::vsnprintf(text, sizeof text, fmt, ap);
  static_cast<MemoryTiff*>(user)->error = std::string(module ? module : "libtiff") + ": " + text;
  return 1;
}
int ignore_warning(TIFF*, void*, const char*, const char*, va_list) {
  return 1;
}

struct TiffCloser {
  void operator()(TIFF* t) const { TIFFClose(t); }
};
using Tiff = std::unique_ptr<TIFF, TiffCloser>;

// Opens `m` through libtiff ("w" or "r"), its errors kept in m.error.
Tiff open_memory(MemoryTiff& m, const char* mode, const std::string& path) {
  std::unique_ptr<TIFFOpenOptions, void (*)(TIFFOpenOptions*)> opts(TIFFOpenOptionsAlloc(),
                                                                    TIFFOpenOptionsFree);
  TIFFOpenOptionsSetErrorHandlerExtR(opts.get(), keep_error, &m);
  TIFFOpenOptionsSetWarningHandlerExtR(opts.get(), ignore_warning, &m);
  Tiff t(TIFFClientOpenExt("block", mode, &m, mem_read, mem_write, mem_seek, mem_close, mem_size,
                           mem_map, mem_unmap, opts.get()));
  if (!t) throw Error(path + ": libtiff cannot open a block in memory: " + m.error);
  return t;
}

int codec_of(const std::string& path, const std::string& compression) {
  check_compression(compression, path);
  if (compression == "ZSTD") return COMPRESSION_ZSTD;
  if (compression == "DEFLATE") return COMPRESSION_ADOBE_DEFLATE;
  if (compression == "LZW") return COMPRESSION_LZW;
  return COMPRESSION_NONE;
}

// The fields of a one-tile TIFF of this spec, as GDAL sets them (the spec's codec and level;
// libtiff takes ZSTD's fast levels, below 1, with a warning, ignored here).
// The predictor is applied outside libtiff (below), so the codec sees the same bytes as with
// libtiff's own, faster.
void set_block_fields(TIFF* t, const GeoTiffSpec& spec, const std::string& path) {
  const auto B = std::uint32_t(spec.block);
  const int codec = codec_of(path, spec.compression);
  TIFFSetField(t, TIFFTAG_IMAGEWIDTH, B);
  TIFFSetField(t, TIFFTAG_IMAGELENGTH, B);
  TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, 32);
  TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, int(spec.band_names.size()));
  TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, SAMPLEFORMAT_IEEEFP);
  TIFFSetField(t, TIFFTAG_PLANARCONFIG, PLANARCONFIG_CONTIG);
  TIFFSetField(t, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  TIFFSetField(t, TIFFTAG_TILEWIDTH, B);
  TIFFSetField(t, TIFFTAG_TILELENGTH, B);
  TIFFSetField(t, TIFFTAG_COMPRESSION, codec);
  const int level = default_level(spec.compression, spec.level);
  if (codec == COMPRESSION_ZSTD) TIFFSetField(t, TIFFTAG_ZSTD_LEVEL, level);
  if (codec == COMPRESSION_ADOBE_DEFLATE) TIFFSetField(t, TIFFTAG_ZIPQUALITY, level);
}

// libtiff's floating-point predictor (Predictor 3) on one row of n float32 samples, `stride`
// samples a pixel: the bytes regrouped by significance, most significant first, then each byte
// less the one `stride` bytes before it. `tmp` holds 4 n bytes.
void predict_row(const float* row, std::size_t n, std::size_t stride, unsigned char* tmp,
                 unsigned char* out) {
  // Each sample's bits as an integer, its bytes taken by shifts: most significant first
  // whatever the host's byte order, and a loop the compiler vectorises.
  unsigned char* p[4] = {tmp, tmp + n, tmp + 2 * n, tmp + 3 * n};
  for (std::size_t i = 0; i < n; ++i) {
    std::uint32_t x;
    std::memcpy(&x, row + i, 4);
    p[0][i] = (unsigned char)(x >> 24);
    p[1][i] = (unsigned char)(x >> 16);
    p[2][i] = (unsigned char)(x >> 8);
    p[3][i] = (unsigned char)x;
  }
  for (std::size_t i = 0; i < stride; ++i) out[i] = tmp[i];
  for (std::size_t i = stride; i < 4 * n; ++i) out[i] = (unsigned char)(tmp[i] - tmp[i - stride]);
}

void unpredict_row(unsigned char* in, std::size_t n, std::size_t stride, float* row) {
  for (std::size_t i = stride; i < 4 * n; ++i) in[i] = (unsigned char)(in[i] + in[i - stride]);
  auto* b = reinterpret_cast<unsigned char*>(row);
  const bool le = host_is_little_endian();
  for (std::size_t k = 0; k < 4; ++k) {
    const unsigned char* plane = in + (le ? 3 - k : k) * n;
    for (std::size_t i = 0; i < n; ++i) b[4 * i + k] = plane[i];
  }
}

}  // namespace

std::string encode_block(const std::string& path, const GeoTiffSpec& spec,
                         const std::vector<const float*>& bands, std::size_t width,
                         std::size_t height) {
  const std::size_t B = spec.block, nb = bands.size(), n = B * nb;
  if (nb != spec.band_names.size() || width > B || height > B)
    throw Error(path + ": internal: a block of " + std::to_string(width) + " x " +
                std::to_string(height) + " pixels and " + std::to_string(nb) + " bands");
  // Megabytes a block, reused by a thread that encodes block after block (the tiled job's
  // writer) rather than allocated and faulted in afresh each time.
  thread_local std::vector<float> px;
  thread_local std::vector<unsigned char> bytes, tmp;
  thread_local std::string tiff;
  px.assign(B * n, 0.0f);  // zeros past the image edge, as GDAL pads
  for (std::size_t r = 0; r < height; ++r)
    for (std::size_t b = 0; b < nb; ++b)
      for (std::size_t c = 0; c < width; ++c) px[r * n + c * nb + b] = bands[b][r * width + c];
  bytes.resize(4 * B * n);
  if (spec.compression == "NONE") {
    std::memcpy(bytes.data(), px.data(), bytes.size());
  } else {
    tmp.resize(4 * n);
    for (std::size_t r = 0; r < B; ++r)
      predict_row(px.data() + r * n, n, nb, tmp.data(), bytes.data() + 4 * r * n);
  }
  MemoryTiff m;
  m.data = std::move(tiff);
  m.data.clear();
  m.data.reserve(bytes.size() + 4096);  // the block and libtiff's directory, one allocation
  std::uint64_t offset = 0, size = 0;
  {
    Tiff t = open_memory(m, "wl", path);
    set_block_fields(t.get(), spec, path);
    if (TIFFWriteEncodedTile(t.get(), 0, bytes.data(), tmsize_t(bytes.size())) < 0)
      throw Error(path + ": compressing a block (" + spec.compression + "): " + m.error);
    offset = TIFFGetStrileOffset(t.get(), 0);
    size = TIFFGetStrileByteCount(t.get(), 0);
  }
  std::string block = m.data.substr(std::size_t(offset), std::size_t(size));
  tiff = std::move(m.data);
  return block;
}

void decode_block(const std::string& path, const GeoTiffSpec& spec, const std::string& bytes,
                  std::size_t width, std::size_t height, const std::vector<float*>& bands) {
  const std::size_t B = spec.block, nb = bands.size(), n = B * nb;
  MemoryTiff m;
  {  // A one-tile TIFF around the bytes, for libtiff to decode.
    Tiff t = open_memory(m, "wl", path);
    set_block_fields(t.get(), spec, path);
    if (TIFFWriteRawTile(t.get(), 0, const_cast<char*>(bytes.data()), tmsize_t(bytes.size())) < 0)
      throw Error(path + ": cannot wrap a block: " + m.error);
  }
  m.pos = 0;
  std::vector<unsigned char> raw(4 * B * n);
  {
    Tiff t = open_memory(m, "r", path);
    if (TIFFReadEncodedTile(t.get(), 0, raw.data(), tmsize_t(raw.size())) != tmsize_t(raw.size()))
      throw Error(path + ": a block of " + std::to_string(bytes.size()) +
                  " bytes does not decode (" + spec.compression + "): " + m.error);
  }
  std::vector<float> px(B * n);
  if (spec.compression == "NONE")
    std::memcpy(px.data(), raw.data(), raw.size());
  else
    for (std::size_t r = 0; r < B; ++r)
      unpredict_row(raw.data() + 4 * r * n, n, nb, px.data() + r * n);
  for (std::size_t r = 0; r < height; ++r)
    for (std::size_t b = 0; b < nb; ++b)
      for (std::size_t c = 0; c < width; ++c) bands[b][r * width + c] = px[r * n + c * nb + b];
}

// --- directories ------------------------------------------------------------------------------

namespace {

constexpr std::uint16_t kShort = 3, kLong = 4, kLong8 = 16;

std::size_t type_bytes(std::uint16_t type) {
  switch (type) {
    case 1:
    case 2:
    case 6:
    case 7:
      return 1;
    case 3:
    case 8:
      return 2;
    case 4:
    case 9:
    case 11:
    case 13:
      return 4;
    default:
      return 8;  // RATIONAL, SRATIONAL, DOUBLE, LONG8, SLONG8, IFD8
  }
}

void put(std::string& s, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) s.push_back(char((v >> (8 * i)) & 0xff));
}

TiffField field(std::uint16_t tag, std::uint16_t type, const std::vector<std::uint64_t>& values) {
  TiffField f{tag, type, values.size(), {}};
  for (std::uint64_t v : values) put(f.bytes, v, int(type_bytes(type)));
  return f;
}

// SHORT where the value fits, as libtiff writes sizes.
TiffField short_or_long(std::uint16_t tag, std::size_t v) {
  return field(tag, v < 65536 ? kShort : kLong, {v});
}

// The fields of level `k` (0: full resolution), in the order libtiff writes their values:
// its own fields by tag, then GDAL's in the order GDAL sets them. The tile arrays are last
// (their values go after every directory); `arrays` says how many.
std::vector<TiffField> level_fields(const CogFields& f, const CogLevel& level, std::size_t k) {
  const GeoTiffSpec& spec = *f.spec;
  const std::size_t nb = spec.band_names.size();
  const int codec = spec.compression == "ZSTD"      ? COMPRESSION_ZSTD
                    : spec.compression == "DEFLATE" ? COMPRESSION_ADOBE_DEFLATE
                    : spec.compression == "LZW"     ? COMPRESSION_LZW
                                                    : COMPRESSION_NONE;
  std::vector<TiffField> out;
  if (k > 0) out.push_back(field(TIFFTAG_SUBFILETYPE, kLong, {FILETYPE_REDUCEDIMAGE}));
  out.push_back(short_or_long(TIFFTAG_IMAGEWIDTH, level.width));
  out.push_back(short_or_long(TIFFTAG_IMAGELENGTH, level.height));
  out.push_back(field(TIFFTAG_BITSPERSAMPLE, kShort, std::vector<std::uint64_t>(nb, 32)));
  out.push_back(field(TIFFTAG_COMPRESSION, kShort, {std::uint64_t(codec)}));
  out.push_back(field(TIFFTAG_PHOTOMETRIC, kShort, {PHOTOMETRIC_MINISBLACK}));
  out.push_back(field(TIFFTAG_SAMPLESPERPIXEL, kShort, {nb}));
  out.push_back(field(TIFFTAG_PLANARCONFIG, kShort, {PLANARCONFIG_CONTIG}));
  if (codec != COMPRESSION_NONE) out.push_back(field(TIFFTAG_PREDICTOR, kShort, {3}));
  out.push_back(short_or_long(TIFFTAG_TILEWIDTH, spec.block));
  out.push_back(short_or_long(TIFFTAG_TILELENGTH, spec.block));
  if (nb > 1)
    out.push_back(field(TIFFTAG_EXTRASAMPLES, kShort, std::vector<std::uint64_t>(nb - 1, 0)));
  out.push_back(field(TIFFTAG_SAMPLEFORMAT, kShort, std::vector<std::uint64_t>(nb, 3)));
  for (const TiffField& g : k == 0 ? f.main : f.every) out.push_back(g);
  const std::uint16_t at = f.bigtiff ? kLong8 : kLong;
  out.push_back(field(TIFFTAG_TILEOFFSETS, at, level.offsets));
  out.push_back(field(TIFFTAG_TILEBYTECOUNTS, at, level.sizes));
  return out;
}

// Directory of `fields` at `at`: entries sorted by tag, then the values that do not fit in an
// entry, each at an even offset, except the tile arrays' (the last two fields), which go to
// `*arrays` (advanced) with their offsets there.
std::string directory(const CogFields& f, std::vector<TiffField> fields, std::uint64_t at,
                      std::uint64_t* arrays, std::string* array_bytes, bool last) {
  const int word = f.bigtiff ? 8 : 4;
  const std::size_t entry = f.bigtiff ? 20 : 12, head = f.bigtiff ? 8 : 2;
  const std::uint64_t values_at = at + head + fields.size() * entry + word;
  std::map<std::uint16_t, std::string> entries;
  std::string values;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const TiffField& x = fields[i];
    std::string e;
    put(e, x.tag, 2);
    put(e, x.type, 2);
    put(e, x.count, word);
    if (x.bytes.size() <= std::size_t(word)) {
      e += x.bytes;
      e.append(word - x.bytes.size(), '\0');
    } else if (i + 2 >= fields.size()) {  // a tile array
      put(e, *arrays, word);
      *array_bytes += x.bytes;
      *arrays += x.bytes.size();
    } else {
      if ((values_at + values.size()) % 2) values.push_back('\0');
      put(e, values_at + values.size(), word);
      values += x.bytes;
    }
    entries[x.tag] = e;
  }
  std::string out;
  put(out, fields.size(), int(head));
  for (const auto& [tag, e] : entries) out += e;
  put(out, last ? 0 : values_at + values.size() + (values.size() % 2), word);
  out += values;
  if (out.size() % 2) out.push_back('\0');
  return out;
}

std::string ghost_area() {
  const std::string body =
      "LAYOUT=IFDS_BEFORE_DATA\nBLOCK_ORDER=ROW_MAJOR\nBLOCK_LEADER=SIZE_AS_UINT4\n"
      "BLOCK_TRAILER=LAST_4_BYTES_REPEATED\nKNOWN_INCOMPATIBLE_EDITION=NO\n ";
  char head[64];
  std::snprintf(head, sizeof head, "GDAL_STRUCTURAL_METADATA_SIZE=%06zu bytes\n", body.size());
  return head + body;
}

}  // namespace

std::string cog_header(const CogFields& f, const std::vector<CogLevel>& levels) {
  std::string out = f.bigtiff ? std::string("II+\0\x08\0\0\0", 8) : std::string("II*\0", 4);
  const int word = f.bigtiff ? 8 : 4;
  const std::uint64_t first_ifd = (out.size() + word + ghost_area().size() + 1) & ~std::uint64_t(1);
  put(out, first_ifd, word);
  out += ghost_area();
  out.resize(first_ifd, '\0');
  // The directories, then the tile arrays; where the arrays start is known once the
  // directories' sizes are, which do not depend on it.
  auto lay_out = [&](std::uint64_t arrays_at, std::string* arrays) {
    std::string dirs;
    for (std::size_t k = 0; k < levels.size(); ++k)
      dirs += directory(f, level_fields(f, levels[k], k), first_ifd + dirs.size(), &arrays_at,
                        arrays, k + 1 == levels.size());
    return dirs;
  };
  std::string scratch, arrays;
  const std::string dirs = lay_out(first_ifd + lay_out(0, &scratch).size(), &arrays);
  return out + dirs + arrays;
}

std::vector<TiffField> gdal_fields(const std::string& path, const std::string& tiff) {
  auto u16 = [&](std::size_t at) {
    return std::uint16_t(get_le(reinterpret_cast<const unsigned char*>(tiff.data()) + at, 2));
  };
  auto u32 = [&](std::size_t at) {
    return std::uint32_t(get_le(reinterpret_cast<const unsigned char*>(tiff.data()) + at, 4));
  };
  if (tiff.size() < 8 || tiff.compare(0, 4, std::string("II*\0", 4)) != 0)
    throw Error(path + ": GDAL's GeoTIFF fields: not a little-endian classic TIFF");
  const std::size_t ifd = u32(4);
  if (ifd + 2 > tiff.size())
    throw Error(path + ": GDAL's GeoTIFF fields: directory at " + std::to_string(ifd) +
                " past the end");
  const std::size_t n = u16(ifd);
  std::vector<std::pair<std::uint64_t, TiffField>> found;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t e = ifd + 2 + 12 * i;
    if (e + 12 > tiff.size())
      throw Error(path + ": GDAL's GeoTIFF fields: entry " + std::to_string(i) + " past the end");
    TiffField x{u16(e), u16(e + 2), u32(e + 4), {}};
    if (x.tag < 33550) continue;
    const std::size_t len = std::size_t(x.count) * type_bytes(x.type);
    const std::size_t at = len <= 4 ? e + 8 : u32(e + 8);
    if (at + len > tiff.size())
      throw Error(path + ": GDAL's GeoTIFF fields: tag " + std::to_string(x.tag) + " past the end");
    x.bytes = tiff.substr(at, len);
    found.emplace_back(at, std::move(x));
  }
  std::stable_sort(found.begin(), found.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<TiffField> out;
  for (auto& [at, x] : found) out.push_back(std::move(x));
  return out;
}

}  // namespace potmap::detail

#endif  // POTMAP_WITH_GDAL
