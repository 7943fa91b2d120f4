// The dictionary file format (layout: include/potmap/dictionary_io.hpp).
#include "potmap/dictionary_io.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include "file_util.hpp"
#include "le_bytes.hpp"
#include "map_checks.hpp"
#include "text_io.hpp"

namespace potmap {

namespace {

using detail::get_f64;
using detail::get_le;
using detail::MapField;

constexpr char kMagic[8] = {'P', 'O', 'T', 'D', 'I', 'C', '\r', '\n'};
constexpr std::size_t kHeaderBytes = 64;
constexpr std::size_t kAtomFixedBytes = 112;
constexpr std::size_t kCrcBytes = 4;
constexpr std::uint32_t kMaxSourceBytes = 65536;

std::string atom_name(std::size_t a) {
  return "atom " + std::to_string(a);
}

[[noreturn]] void fail_at(const std::string& path, std::size_t offset, const std::string& what) {
  throw InputError(path + ": byte offset " + std::to_string(offset) + ": " + what);
}

// Reads fields in order, checking every length against what is left before the checksum.
class Cursor {
 public:
  Cursor(const std::string& path, const unsigned char* b, std::size_t end)
      : path_(path), b_(b), end_(end) {}
  std::size_t at() const { return at_; }
  void need(std::uint64_t bytes, const std::string& what) const {
    if (bytes > end_ - at_)
      fail_at(path_, at_,
              what + " needs " + std::to_string(bytes) + " bytes, " + std::to_string(end_ - at_) +
                  " are left before the checksum (truncated)");
  }
  std::uint64_t uint(int n) {
    const std::uint64_t v = get_le(b_ + at_, n);
    at_ += n;
    return v;
  }
  double f64(const std::string& what, bool positive = false) {
    const double v = get_f64(b_ + at_);
    if (!std::isfinite(v) || (positive && !(v > 0)))
      fail_at(path_, at_,
              what + " = " + detail::format_double(v) +
                  (std::isfinite(v) ? ": must be > 0" : ": value is not finite"));
    at_ += 8;
    return v;
  }
  void zero(int n, const std::string& what) {
    const std::uint64_t v = get_le(b_ + at_, n);
    if (v != 0) fail_at(path_, at_, what + " is " + std::to_string(v) + ", not 0");
    at_ += n;
  }
  // count * per doubles, each checked; `name` gets the element index appended.
  void doubles(std::vector<double>& out, std::uint64_t count, int per, MapField field,
               const std::string& name) {
    const std::uint64_t limit = (end_ - at_) / 8;
    if (count > limit / std::uint64_t(per))
      fail_at(path_, at_,
              name + ": " + std::to_string(count) + " x " + std::to_string(per) +
                  " values do not fit in the " + std::to_string(end_ - at_) +
                  " bytes left before the checksum (truncated or corrupt count)");
    out.resize(static_cast<std::size_t>(count * per));
    for (std::size_t i = 0; i < out.size(); ++i) {
      const double v = get_f64(b_ + at_);
      if (const char* why = detail::map_value_problem(field, v)) {
        std::string idx = std::to_string(i / per);
        if (per > 1) idx += "][" + std::to_string(i % per);
        fail_at(path_, at_, name + "[" + idx + "] = " + detail::format_double(v) + ": " + why);
      }
      out[i] = v;
      at_ += 8;
    }
  }
  std::string text(std::size_t n) {
    std::string s(reinterpret_cast<const char*>(b_ + at_), n);
    at_ += n;
    return s;
  }

 private:
  const std::string& path_;
  const unsigned char* b_;
  std::size_t end_;
  std::size_t at_ = 0;
};

void check_finite(double v, const std::string& where, const std::string& what) {
  if (!std::isfinite(v))
    throw ArgumentError(where + what + " = " + detail::format_double(v) + ": not finite");
}

}  // namespace

void validate_dictionary(const Dictionary& dict, const std::string& source) {
  const std::string pre = source.empty() ? "" : source + ": ";
  if (dict.dim != 2 && dict.dim != 3)
    throw ArgumentError(pre + "dictionary dimension " + std::to_string(dict.dim) +
                        " (must be 2 or 3)");
  if (!(dict.scale > 0) || !std::isfinite(dict.scale))
    throw ArgumentError(pre + "dictionary scale " + detail::format_double(dict.scale) +
                        " (must be finite and > 0)");
  if (!(dict.max_range > 0) || !std::isfinite(dict.max_range))
    throw ArgumentError(pre + "dictionary max_range " + detail::format_double(dict.max_range) +
                        " (must be finite and > 0)");
  if (dict.sectors < 1)
    throw ArgumentError(pre + "dictionary sectors " + std::to_string(dict.sectors) +
                        " (must be >= 1)");
  const std::size_t D = dict.dim;
  for (std::size_t a = 0; a < dict.atoms.size(); ++a) {
    const Atom& at = dict.atoms[a];
    const Sector& s = at.sector;
    const std::string where = pre + atom_name(a) + ": ";
    if (s.dim != dict.dim || at.kernels.dim != dict.dim)
      throw ArgumentError(where + "dimension " + std::to_string(s.dim) + " (kernels " +
                          std::to_string(at.kernels.dim) + "), dictionary " +
                          std::to_string(dict.dim));
    if (s.index < 0 || s.index >= dict.sectors)
      throw ArgumentError(where + "sector index " + std::to_string(s.index) + " outside [0, " +
                          std::to_string(dict.sectors) + ")");
    if (s.scale != dict.scale)
      throw ArgumentError(where + "scale " + detail::format_double(s.scale) +
                          " differs from the dictionary's " + detail::format_double(dict.scale));
    if (!(s.max_range > 0) || !std::isfinite(s.max_range))
      throw ArgumentError(where + "max_range " + detail::format_double(s.max_range) +
                          " (must be finite and > 0)");
    if (s.hits.size() % D || s.free.size() % D)
      throw ArgumentError(where + "hits/free arrays of " + std::to_string(s.hits.size()) + "/" +
                          std::to_string(s.free.size()) + " values are not a multiple of dim " +
                          std::to_string(D));
    for (int d = 0; d < 3; ++d) {
      check_finite(s.centre[d], where, "centre[" + std::to_string(d) + "]");
      check_finite(s.sensor[d], where, "sensor[" + std::to_string(d) + "]");
    }
    for (std::size_t i = 0; i < s.hits.size(); ++i)
      check_finite(s.hits[i], where, "hits[" + std::to_string(i) + "]");
    for (std::size_t i = 0; i < s.free.size(); ++i)
      check_finite(s.free[i], where, "free[" + std::to_string(i) + "]");
    if (at.kernels.has_bias) throw ArgumentError(where + "atom kernels must not have a bias");
    at.kernels.validate(where.substr(0, where.size() - 2));
    if (at.source.size() > kMaxSourceBytes)
      throw ArgumentError(where + "source text of " + std::to_string(at.source.size()) +
                          " bytes (at most " + std::to_string(kMaxSourceBytes) + ")");
  }
}

void write_dictionary(const Dictionary& dict, const std::string& path) {
  validate_dictionary(dict, path);
  using detail::put_f64;
  using detail::put_u32;
  using detail::put_u64;
  std::size_t total = kHeaderBytes + kCrcBytes;
  for (const Atom& a : dict.atoms)
    total += kAtomFixedBytes + a.source.size() +
             8 * (a.sector.hits.size() + a.sector.free.size() + a.kernels.position.size() +
                  3 * a.kernels.size());
  std::string out(kMagic, sizeof kMagic);
  out.reserve(total);
  put_u32(out, kDictionaryFormatVersion);
  put_u32(out, static_cast<std::uint32_t>(dict.dim));
  put_f64(out, dict.scale);
  put_f64(out, dict.max_range);
  put_u32(out, static_cast<std::uint32_t>(dict.sectors));
  put_u32(out, 0);
  put_u64(out, dict.atoms.size());
  put_u64(out, total);
  put_u64(out, 0);
  for (const Atom& a : dict.atoms) {
    const Sector& s = a.sector;
    put_u32(out, static_cast<std::uint32_t>(s.index));
    put_u32(out, 0);
    for (double v : s.centre) put_f64(out, v);
    for (double v : s.sensor) put_f64(out, v);
    put_f64(out, s.scale);
    put_f64(out, s.max_range);
    put_u64(out, static_cast<std::uint64_t>(a.scan_index));
    put_u64(out, s.num_hits());
    put_u64(out, s.num_free());
    put_u64(out, a.kernels.size());
    put_u32(out, static_cast<std::uint32_t>(a.source.size()));
    put_u32(out, 0);
    out += a.source;
    for (double v : s.hits) put_f64(out, v);
    for (double v : s.free) put_f64(out, v);
    for (double v : a.kernels.position) put_f64(out, v);
    for (double v : a.kernels.gamma) put_f64(out, v);
    for (double v : a.kernels.w_mean) put_f64(out, v);
    for (double v : a.kernels.w_var) put_f64(out, v);
  }
  put_u32(out, detail::crc32_of(reinterpret_cast<const unsigned char*>(out.data()), out.size()));
  detail::write_file_atomically(path, out);
}

Dictionary read_dictionary(const std::string& path) {
  const std::string bytes = detail::read_whole_file(path);
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::size_t size = bytes.size();
  if (size < sizeof kMagic && std::memcmp(b, kMagic, size) == 0)
    fail_at(path, size, "truncated: " + std::to_string(size) + " bytes");
  if (size < sizeof kMagic || std::memcmp(b, kMagic, sizeof kMagic) != 0)
    fail_at(path, 0,
            "not a potmap dictionary: magic " +
                detail::quote_value(std::string_view(bytes).substr(0, sizeof kMagic)) +
                " (expected 'POTDIC\\r\\n')");
  if (size < 16)
    fail_at(path, size, "truncated: " + std::to_string(size) + " bytes, no version field");
  const std::uint32_t version = static_cast<std::uint32_t>(get_le(b + 8, 4));
  if (version != kDictionaryFormatVersion)
    fail_at(path, 8,
            "unsupported format version " + std::to_string(version) +
                " (this build reads version " + std::to_string(kDictionaryFormatVersion) + ")");
  const std::uint32_t dim = static_cast<std::uint32_t>(get_le(b + 12, 4));
  if (dim != 2 && dim != 3)
    fail_at(path, 12, "dimension " + std::to_string(dim) + " (must be 2 or 3)");
  if (size < kHeaderBytes + kCrcBytes)
    fail_at(path, size,
            "truncated: " + std::to_string(size) + " bytes, the header alone needs " +
                std::to_string(kHeaderBytes + kCrcBytes));
  const std::uint64_t stored_size = get_le(b + 48, 8);
  if (stored_size != size)
    fail_at(path, 48,
            "the header gives a file size of " + std::to_string(stored_size) +
                " bytes, the file has " + std::to_string(size) +
                (stored_size > size ? " (truncated)" : " (trailing bytes or corrupt header)"));
  const std::size_t crc_at = size - kCrcBytes;
  const std::uint32_t stored = static_cast<std::uint32_t>(get_le(b + crc_at, 4));
  const std::uint32_t actual = detail::crc32_of(b, crc_at);
  if (stored != actual) {
    char m[128];
    std::snprintf(m, sizeof m,
                  "checksum mismatch: stored CRC-32 %08x, computed %08x (corrupt file)", stored,
                  actual);
    fail_at(path, crc_at, m);
  }

  Cursor c(path, b, crc_at);
  c.uint(8);  // magic, then version and dim: checked above
  c.uint(8);
  Dictionary dict;
  dict.dim = static_cast<int>(dim);
  dict.scale = c.f64("scale", true);
  dict.max_range = c.f64("max_range", true);
  const std::size_t sectors_at = c.at();
  const std::uint64_t sectors = c.uint(4);
  if (sectors < 1 || sectors > std::uint64_t(std::numeric_limits<int>::max()))
    fail_at(path, sectors_at, "sectors " + std::to_string(sectors) + " (must be >= 1)");
  dict.sectors = static_cast<int>(sectors);
  c.zero(4, "reserved field");
  const std::size_t count_at = c.at();
  const std::uint64_t count = c.uint(8);
  c.uint(8);  // file size: checked above
  c.zero(8, "reserved field");
  // Every atom takes at least its fixed part: a count beyond that cannot be real.
  if (count > (crc_at - kHeaderBytes) / kAtomFixedBytes)
    fail_at(path, count_at,
            "atom count " + std::to_string(count) + " cannot fit in a file of " +
                std::to_string(size) + " bytes");
  dict.atoms.resize(static_cast<std::size_t>(count));
  for (std::size_t a = 0; a < dict.atoms.size(); ++a) {
    Atom& at = dict.atoms[a];
    Sector& s = at.sector;
    const std::string name = atom_name(a);
    c.need(kAtomFixedBytes, name);
    s.dim = dict.dim;
    at.kernels.dim = dict.dim;
    const std::size_t index_at = c.at();
    const std::int32_t index = static_cast<std::int32_t>(c.uint(4));
    if (index < 0 || index >= dict.sectors)
      fail_at(path, index_at,
              name + " sector index " + std::to_string(index) + " outside [0, " +
                  std::to_string(dict.sectors) + ")");
    s.index = index;
    c.zero(4, name + " reserved field");
    for (int d = 0; d < 3; ++d) s.centre[d] = c.f64(name + " centre[" + std::to_string(d) + "]");
    for (int d = 0; d < 3; ++d) s.sensor[d] = c.f64(name + " sensor[" + std::to_string(d) + "]");
    const std::size_t scale_at = c.at();
    s.scale = c.f64(name + " scale", true);
    if (s.scale != dict.scale)
      fail_at(path, scale_at,
              name + " scale " + detail::format_double(s.scale) +
                  " differs from the dictionary's " + detail::format_double(dict.scale));
    s.max_range = c.f64(name + " max_range", true);
    at.scan_index = static_cast<std::int64_t>(c.uint(8));
    const std::uint64_t nh = c.uint(8), nf = c.uint(8), nk = c.uint(8);
    const std::size_t len_at = c.at();
    const std::uint64_t len = c.uint(4);
    if (len > kMaxSourceBytes)
      fail_at(path, len_at,
              name + " source length " + std::to_string(len) + " (at most " +
                  std::to_string(kMaxSourceBytes) + ")");
    c.zero(4, name + " reserved field");
    c.need(len, name + " source text");
    at.source = c.text(static_cast<std::size_t>(len));
    c.doubles(s.hits, nh, dim, MapField::position, name + " hits");
    c.doubles(s.free, nf, dim, MapField::position, name + " free");
    c.doubles(at.kernels.position, nk, dim, MapField::position, name + " kernel position");
    c.doubles(at.kernels.gamma, nk, 1, MapField::gamma, name + " kernel gamma");
    c.doubles(at.kernels.w_mean, nk, 1, MapField::w_mean, name + " kernel w_mean");
    c.doubles(at.kernels.w_var, nk, 1, MapField::w_var, name + " kernel w_var");
  }
  if (c.at() != crc_at)
    fail_at(path, c.at(),
            std::to_string(crc_at - c.at()) + " unexpected bytes after the last atom");
  return dict;
}

}  // namespace potmap
