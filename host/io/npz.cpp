#include "io/npz.hpp"

#include <zip.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <memory>
#include <sstream>

#include "io/file_util.hpp"
#include "potmap/error.hpp"

namespace potmap::npz {

namespace {

std::string zip_code_message(int code) {
  zip_error_t e;
  zip_error_init_with_code(&e, code);
  std::string m = zip_error_strerror(&e);
  zip_error_fini(&e);
  return m;
}

struct ArchiveCloser {
  void operator()(zip_t* z) const { zip_discard(z); }
};
struct FileCloser {
  void operator()(zip_file_t* f) const { zip_fclose(f); }
};

// Deflate cannot expand data by more than about 1032:1, so a member that claims more is corrupt
// (or a zip bomb); checked before anything is allocated.
constexpr std::uint64_t kMaxDeflateRatio = 1100;

}  // namespace

std::map<std::string, npy::Array> read(const std::string& path) {
  int code = 0;
  std::unique_ptr<zip_t, ArchiveCloser> za(
      zip_open(path.c_str(), ZIP_RDONLY | ZIP_CHECKCONS, &code));
  if (!za)
    throw InputError(path + ": cannot open as a zip (.npz) archive: " + zip_code_message(code));
  const zip_int64_t entries = zip_get_num_entries(za.get(), 0);
  std::map<std::string, npy::Array> out;
  for (zip_int64_t i = 0; i < entries; ++i) {
    zip_stat_t st;
    zip_stat_init(&st);
    if (zip_stat_index(za.get(), i, 0, &st) != 0 || !(st.valid & ZIP_STAT_NAME))
      throw InputError(path + ": zip member " + std::to_string(i) +
                       ": cannot read its directory entry: " + zip_strerror(za.get()));
    const std::string name = st.name;
    if (name.size() < 5 || name.compare(name.size() - 4, 4, ".npy") != 0) continue;
    const std::string key = name.substr(0, name.size() - 4);
    const std::string where = path + ": " + name;
    if (!(st.valid & ZIP_STAT_SIZE) || !(st.valid & ZIP_STAT_COMP_SIZE))
      throw InputError(where + ": the zip directory gives no size");
    if (st.size > std::numeric_limits<std::size_t>::max() / 2 ||
        st.size > st.comp_size * kMaxDeflateRatio + 4096) {
      std::ostringstream m;
      m << where << ": implausible size " << st.size << " bytes for " << st.comp_size
        << " compressed bytes (corrupt archive)";
      throw InputError(m.str());
    }
    std::unique_ptr<zip_file_t, FileCloser> f(zip_fopen_index(za.get(), i, 0));
    if (!f) throw InputError(where + ": cannot open member: " + zip_strerror(za.get()));
    // Memory grows with the bytes that actually arrive, not with what the directory claims.
    const std::size_t want = static_cast<std::size_t>(st.size);
    std::string bytes;
    bytes.reserve(std::min<std::size_t>(want, std::size_t(1) << 26));
    std::vector<char> chunk(std::min<std::size_t>(std::max<std::size_t>(want, 1), 1 << 20));
    std::size_t got = 0;
    while (got < want) {
      const zip_int64_t r = zip_fread(f.get(), chunk.data(), std::min(chunk.size(), want - got));
      if (r < 0)
        throw InputError(where + ": byte offset " + std::to_string(got) +
                         ": read error: " + zip_file_strerror(f.get()));
      if (r == 0) break;
      bytes.append(chunk.data(), static_cast<std::size_t>(r));
      got += static_cast<std::size_t>(r);
    }
    if (got != want)
      throw InputError(where + ": truncated: " + std::to_string(got) + " of " +
                       std::to_string(want) + " bytes could be read");
    // libzip verifies the CRC-32 when it reaches the end of the member: read past the end.
    char extra;
    const zip_int64_t r = zip_fread(f.get(), &extra, 1);
    if (r < 0) throw InputError(where + ": " + zip_file_strerror(f.get()));
    if (r > 0) throw InputError(where + ": member is longer than its directory entry says");
    if (out.count(key)) throw InputError(path + ": duplicate member '" + name + "'");
    out.emplace(key, npy::parse(bytes.data(), bytes.size(), where));
  }
  return out;
}

void write(const std::string& path, const std::vector<std::pair<std::string, npy::Array>>& arrays) {
  // The archive is built in memory and written with AtomicFile, so that a failure never leaves
  // a partial file at `path` (libzip's own temporary-file logic is bypassed on purpose).
  std::vector<std::string> images;
  images.reserve(arrays.size());
  for (const auto& [key, a] : arrays) images.push_back(npy::serialize(a));

  zip_error_t err;
  zip_error_init(&err);
  zip_source_t* src = zip_source_buffer_create(nullptr, 0, 0, &err);
  if (!src) throw Error(path + ": cannot create zip buffer: " + zip_error_strerror(&err));
  zip_source_keep(src);  // survives zip_close so its content can be read back
  std::unique_ptr<zip_source_t, decltype(&zip_source_free)> keep(src, &zip_source_free);
  zip_t* raw = zip_open_from_source(src, ZIP_TRUNCATE, &err);
  if (!raw) {
    const std::string m = zip_error_strerror(&err);
    zip_error_fini(&err);
    throw Error(path + ": cannot create zip archive: " + m);
  }
  std::unique_ptr<zip_t, ArchiveCloser> za(raw);
  for (std::size_t i = 0; i < arrays.size(); ++i) {
    const std::string name = arrays[i].first + ".npy";
    zip_source_t* s = zip_source_buffer(za.get(), images[i].data(), images[i].size(), 0);
    if (!s) throw Error(path + ": " + name + ": " + zip_strerror(za.get()));
    const zip_int64_t idx = zip_file_add(za.get(), name.c_str(), s, ZIP_FL_OVERWRITE);
    if (idx < 0) {
      zip_source_free(s);
      throw Error(path + ": cannot add " + name + ": " + zip_strerror(za.get()));
    }
    if (zip_set_file_compression(za.get(), idx, ZIP_CM_STORE, 0) != 0)
      throw Error(path + ": " + name + ": " + zip_strerror(za.get()));
  }
  if (zip_close(za.get()) != 0)
    throw Error(path + ": cannot finish zip archive: " + zip_strerror(za.get()));
  za.release();  // zip_close freed it

  zip_stat_t st;
  zip_stat_init(&st);
  if (zip_source_stat(src, &st) != 0 || !(st.valid & ZIP_STAT_SIZE) || zip_source_open(src) != 0)
    throw Error(path + ": cannot read back the zip buffer");
  std::string bytes(static_cast<std::size_t>(st.size), '\0');
  const zip_int64_t n = zip_source_read(src, bytes.data(), bytes.size());
  zip_source_close(src);
  if (n < 0 || static_cast<std::size_t>(n) != bytes.size())
    throw Error(path + ": cannot read back the zip buffer");
  detail::write_file_atomically(path, bytes);
}

}  // namespace potmap::npz
