// The dictionary file format (layout: include/potmap/pot/dictionary_io.hpp).
#include "potmap/pot/dictionary_io.hpp"

#include <cmath>
#include <limits>

#include "io/container.hpp"
#include "io/text_io.hpp"
#include "map/map_checks.hpp"

namespace potmap {

namespace {

using detail::MapField;

constexpr std::size_t kHeaderBytes = 64;
constexpr std::size_t kSizeField = 48;  // the whole file size, u64
constexpr detail::ContainerLayout kLayout{"POTDIC\r\n", "a potmap dictionary",
                                          kDictionaryFormatVersion, kHeaderBytes, kSizeField};
constexpr std::size_t kAtomFixedBytes = 112;
constexpr std::size_t kCrcBytes = 4;
constexpr std::uint32_t kMaxSourceBytes = 65536;

std::string atom_name(std::size_t a) {
  return "atom " + std::to_string(a);
}

// Reads fields in order, checking every length against what is left before the checksum.
class Cursor {
 public:
  explicit Cursor(const detail::ContainerReader& r) : r_(r), end_(r.payload_end()) {}
  std::size_t at() const { return at_; }
  void need(std::uint64_t bytes, const std::string& what) const {
    if (bytes > end_ - at_)
      r_.fail(at_, what + " needs " + std::to_string(bytes) + " bytes, " +
                       std::to_string(end_ - at_) + " are left before the checksum (truncated)");
  }
  std::uint64_t uint(int n) {
    const std::uint64_t v = r_.uint(at_, n);
    at_ += n;
    return v;
  }
  double f64(const std::string& what, bool positive = false) {
    const double v = r_.f64(at_);
    if (!std::isfinite(v) || (positive && !(v > 0)))
      r_.fail(at_, what + " = " + detail::format_double(v) +
                       (std::isfinite(v) ? ": must be > 0" : ": value is not finite"));
    at_ += 8;
    return v;
  }
  void zero(int n, const std::string& what) {
    const std::uint64_t v = r_.uint(at_, n);
    if (v != 0) r_.fail(at_, what + " is " + std::to_string(v) + ", not 0");
    at_ += n;
  }
  // count * per doubles, each checked; `name` gets the element index appended.
  void doubles(std::vector<double>& out, std::uint64_t count, int per, MapField field,
               const std::string& name) {
    const std::uint64_t limit = (end_ - at_) / 8;
    if (count > limit / std::uint64_t(per))
      r_.fail(at_, name + ": " + std::to_string(count) + " x " + std::to_string(per) +
                       " values do not fit in the " + std::to_string(end_ - at_) +
                       " bytes left before the checksum (truncated or corrupt count)");
    out.resize(static_cast<std::size_t>(count * per));
    for (std::size_t i = 0; i < out.size(); ++i) {
      const double v = r_.f64(at_);
      if (const char* why = detail::map_value_problem(field, v)) {
        std::string idx = std::to_string(i / per);
        if (per > 1) idx += "][" + std::to_string(i % per);
        r_.fail(at_, name + "[" + idx + "] = " + detail::format_double(v) + ": " + why);
      }
      out[i] = v;
      at_ += 8;
    }
  }
  std::string text(std::size_t n) {
    std::string s(reinterpret_cast<const char*>(r_.data() + at_), n);
    at_ += n;
    return s;
  }

 private:
  const detail::ContainerReader& r_;
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
  std::size_t total = kHeaderBytes + kCrcBytes;
  for (const Atom& a : dict.atoms)
    total += kAtomFixedBytes + a.source.size() +
             8 * (a.sector.hits.size() + a.sector.free.size() + a.kernels.position.size() +
                  3 * a.kernels.size());
  detail::ContainerWriter out(kLayout, total);
  out.u32(static_cast<std::uint32_t>(dict.dim));
  out.f64(dict.scale);
  out.f64(dict.max_range);
  out.u32(static_cast<std::uint32_t>(dict.sectors));
  out.u32(0);
  out.u64(dict.atoms.size());
  out.u64(0);  // the file size: filled in by finish()
  out.u64(0);
  for (const Atom& a : dict.atoms) {
    const Sector& s = a.sector;
    out.u32(static_cast<std::uint32_t>(s.index));
    out.u32(0);
    out.f64s(s.centre);
    out.f64s(s.sensor);
    out.f64(s.scale);
    out.f64(s.max_range);
    out.u64(static_cast<std::uint64_t>(a.scan_index));
    out.u64(s.num_hits());
    out.u64(s.num_free());
    out.u64(a.kernels.size());
    out.u32(static_cast<std::uint32_t>(a.source.size()));
    out.u32(0);
    out.bytes(a.source);
    out.f64s(s.hits);
    out.f64s(s.free);
    out.f64s(a.kernels.position);
    out.f64s(a.kernels.gamma);
    out.f64s(a.kernels.w_mean);
    out.f64s(a.kernels.w_var);
  }
  out.finish(path);
}

Dictionary read_dictionary(const std::string& path) {
  const detail::ContainerReader r(path, kLayout);
  const std::uint32_t dim = r.u32(12);
  if (dim != 2 && dim != 3) r.fail(12, "dimension " + std::to_string(dim) + " (must be 2 or 3)");
  r.verify();
  const std::size_t size = r.size();
  const std::size_t crc_at = r.payload_end();

  Cursor c(r);
  c.uint(8);  // magic, then version and dim: checked above
  c.uint(8);
  Dictionary dict;
  dict.dim = static_cast<int>(dim);
  dict.scale = c.f64("scale", true);
  dict.max_range = c.f64("max_range", true);
  const std::size_t sectors_at = c.at();
  const std::uint64_t sectors = c.uint(4);
  if (sectors < 1 || sectors > std::uint64_t(std::numeric_limits<int>::max()))
    r.fail(sectors_at, "sectors " + std::to_string(sectors) + " (must be >= 1)");
  dict.sectors = static_cast<int>(sectors);
  c.zero(4, "reserved field");
  const std::size_t count_at = c.at();
  const std::uint64_t count = c.uint(8);
  c.uint(8);  // file size: checked above
  c.zero(8, "reserved field");
  // Every atom takes at least its fixed part: a count beyond that cannot be real.
  if (count > (crc_at - kHeaderBytes) / kAtomFixedBytes)
    r.fail(count_at, "atom count " + std::to_string(count) + " cannot fit in a file of " +
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
      r.fail(index_at, name + " sector index " + std::to_string(index) + " outside [0, " +
                           std::to_string(dict.sectors) + ")");
    s.index = index;
    c.zero(4, name + " reserved field");
    for (int d = 0; d < 3; ++d) s.centre[d] = c.f64(name + " centre[" + std::to_string(d) + "]");
    for (int d = 0; d < 3; ++d) s.sensor[d] = c.f64(name + " sensor[" + std::to_string(d) + "]");
    const std::size_t scale_at = c.at();
    s.scale = c.f64(name + " scale", true);
    if (s.scale != dict.scale)
      r.fail(scale_at, name + " scale " + detail::format_double(s.scale) +
                           " differs from the dictionary's " + detail::format_double(dict.scale));
    s.max_range = c.f64(name + " max_range", true);
    at.scan_index = static_cast<std::int64_t>(c.uint(8));
    const std::uint64_t nh = c.uint(8), nf = c.uint(8), nk = c.uint(8);
    const std::size_t len_at = c.at();
    const std::uint64_t len = c.uint(4);
    if (len > kMaxSourceBytes)
      r.fail(len_at, name + " source length " + std::to_string(len) + " (at most " +
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
    r.fail(c.at(), std::to_string(crc_at - c.at()) + " unexpected bytes after the last atom");
  return dict;
}

}  // namespace potmap
