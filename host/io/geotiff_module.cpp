// libpotmap's side of the GDAL module: in a shared build the GeoTIFF writer
// (geotiff_writer.cpp) and GDAL are a module of their own, libpotmap_gdal.so, next to
// libpotmap, loaded on the first GeoTIFF call. GDAL's hundred-odd libraries would otherwise
// cost every process that links libpotmap their dynamic loading (docs/raster-scale.md), whether
// it writes a GeoTIFF or not. Built only into the shared library (CMakeLists.txt); the objects,
// and the tests that link them, have the writer itself.
#include <dlfcn.h>

#include <mutex>
#include <string>

#include "io/geotiff_writer.hpp"
#include "potmap/error.hpp"

namespace potmap::detail {

namespace {

using WriteCog = void (*)(const std::string*, const GeoTiffSpec*, const BlockFill*,
                          const std::function<void(double)>*);
using WriteCogEncoded = void (*)(const std::string*, const GeoTiffSpec*, const EncodedBlockSource*,
                                 const std::function<void(double)>*);
using EncodeBlock = void (*)(const std::string*, const GeoTiffSpec*,
                             const std::vector<const float*>*, std::size_t, std::size_t,
                             std::string*);
using DecodeBlock = void (*)(const std::string*, const GeoTiffSpec*, const std::string*,
                             std::size_t, std::size_t, const std::vector<float*>*);
using ReadBand = void (*)(const std::string*, int, GeoTiffImage*);
using CheckCrs = void (*)(const std::string*, const std::string*);

struct Module {
  std::string path, error;
  WriteCog write_cog = nullptr;
  WriteCogEncoded write_cog_encoded = nullptr;
  EncodeBlock encode_block = nullptr;
  DecodeBlock decode_block = nullptr;
  ReadBand read_band = nullptr;
  CheckCrs check_crs = nullptr;
};

// The module's path: libpotmap_gdal.so in the folder libpotmap was loaded from.
std::string module_path() {
  Dl_info info{};
  std::string dir;
  if (::dladdr(reinterpret_cast<void*>(&module_path), &info) && info.dli_fname) {
    dir = info.dli_fname;
    const std::size_t slash = dir.rfind('/');
    dir = slash == std::string::npos ? std::string() : dir.substr(0, slash + 1);
  }
  return dir + "libpotmap_gdal.so";
}

const Module& module() {
  static Module m;
  static std::once_flag once;
  std::call_once(once, [] {
    m.path = module_path();
    void* h = ::dlopen(m.path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!h) {
      const char* why = ::dlerror();
      m.error = why ? why : "dlopen failed";
      return;
    }
    m.write_cog = reinterpret_cast<WriteCog>(::dlsym(h, "potmap_gdal_write_cog"));
    m.write_cog_encoded =
        reinterpret_cast<WriteCogEncoded>(::dlsym(h, "potmap_gdal_write_cog_encoded"));
    m.encode_block = reinterpret_cast<EncodeBlock>(::dlsym(h, "potmap_gdal_encode_block"));
    m.decode_block = reinterpret_cast<DecodeBlock>(::dlsym(h, "potmap_gdal_decode_block"));
    m.read_band = reinterpret_cast<ReadBand>(::dlsym(h, "potmap_gdal_read_geotiff_band"));
    m.check_crs = reinterpret_cast<CheckCrs>(::dlsym(h, "potmap_gdal_check_crs"));
    if (!m.write_cog || !m.write_cog_encoded || !m.encode_block || !m.decode_block ||
        !m.read_band || !m.check_crs)
      m.error = "not potmap's GDAL module";
  });
  return m;
}

// The module, or an Error naming the file that needed it and the module.
const Module& loaded(const std::string& path) {
  const Module& m = module();
  if (!m.error.empty())
    throw Error(path + ": GeoTIFF support (GDAL) is a module of this potmap, " + m.path +
                ", which cannot be loaded: " + m.error);
  return m;
}

}  // namespace

void write_cog(const std::string& path, const GeoTiffSpec& spec, const BlockFill& fill,
               const std::function<void(double)>& progress) {
  loaded(path).write_cog(&path, &spec, &fill, &progress);
}

void write_cog_encoded(const std::string& path, const GeoTiffSpec& spec,
                       const EncodedBlockSource& source,
                       const std::function<void(double)>& progress) {
  loaded(path).write_cog_encoded(&path, &spec, &source, &progress);
}

std::string encode_block(const std::string& path, const GeoTiffSpec& spec,
                         const std::vector<const float*>& bands, std::size_t width,
                         std::size_t height) {
  std::string out;
  loaded(path).encode_block(&path, &spec, &bands, width, height, &out);
  return out;
}

void decode_block(const std::string& path, const GeoTiffSpec& spec, const std::string& bytes,
                  std::size_t width, std::size_t height, const std::vector<float*>& bands) {
  loaded(path).decode_block(&path, &spec, &bytes, width, height, &bands);
}

GeoTiffImage read_geotiff_band(const std::string& path, int band) {
  GeoTiffImage im;
  loaded(path).read_band(&path, band, &im);
  return im;
}

void check_crs(const std::string& crs, const std::string& path) {
  loaded(path).check_crs(&crs, &path);
}

bool geotiff_available() {
  return true;  // built with GDAL; a module that fails to load is an error naming it
}

}  // namespace potmap::detail
