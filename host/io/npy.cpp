#include "io/npy.hpp"

#include <cstring>
#include <limits>
#include <sstream>

#include "io/file_util.hpp"
#include "potmap/error.hpp"

namespace potmap::npy {

namespace {

constexpr unsigned char kMagic[6] = {0x93, 'N', 'U', 'M', 'P', 'Y'};

// Elements are decoded byte by byte, so the host's own byte order never matters.
std::uint64_t load_le(const unsigned char* p, std::size_t n) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < n; ++i) v |= std::uint64_t(p[i]) << (8 * i);
  return v;
}

void store_le(unsigned char* p, std::uint64_t v, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) p[i] = static_cast<unsigned char>(v >> (8 * i));
}

bool mul_overflows(std::size_t a, std::size_t b, std::size_t& out) {
  if (a != 0 && b > std::numeric_limits<std::size_t>::max() / a) return true;
  out = a * b;
  return false;
}

std::string quoted(const std::string& s) {
  std::string r = "'";
  for (char c : s) {
    if (c >= 32 && c < 127)
      r += c;
    else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", static_cast<unsigned char>(c));
      r += buf;
    }
  }
  return r + "'";
}

// The header is a Python dict literal; this reads only the subset NumPy writes (string keys,
// string / bool / tuple-of-int values) and names the byte offset of anything else.
class HeaderParser {
 public:
  HeaderParser(const std::string& text, std::size_t base, const std::string& where)
      : s_(text), base_(base), where_(where) {}

  void parse(std::string& descr, bool& fortran, std::vector<std::size_t>& shape) {
    bool have_descr = false, have_fortran = false, have_shape = false;
    skip_ws();
    expect('{');
    while (true) {
      skip_ws();
      if (peek() == '}') {
        ++i_;
        break;
      }
      const std::size_t key_at = i_;
      const std::string key = string_value();
      skip_ws();
      expect(':');
      skip_ws();
      if (key == "descr") {
        if (have_descr) fail(key_at, "duplicate key 'descr'");
        have_descr = true;
        if (peek() == '[')
          fail(i_, "structured dtype (a list of fields) is not supported, only plain numbers");
        descr = string_value();
      } else if (key == "fortran_order") {
        if (have_fortran) fail(key_at, "duplicate key 'fortran_order'");
        have_fortran = true;
        fortran = bool_value();
      } else if (key == "shape") {
        if (have_shape) fail(key_at, "duplicate key 'shape'");
        have_shape = true;
        shape = tuple_value();
      } else {
        fail(key_at, "unexpected header key " + quoted(key) +
                         " (expected 'descr', 'fortran_order', 'shape')");
      }
      skip_ws();
      if (peek() == ',') {
        ++i_;
        continue;
      }
      skip_ws();
      expect('}');
      break;
    }
    skip_ws();
    if (i_ != s_.size()) fail(i_, "unexpected text after the header dict");
    if (!have_descr) fail(0, "header has no 'descr'");
    if (!have_fortran) fail(0, "header has no 'fortran_order'");
    if (!have_shape) fail(0, "header has no 'shape'");
  }

 private:
  [[noreturn]] void fail(std::size_t at, const std::string& what) const {
    std::ostringstream m;
    m << where_ << ": byte offset " << base_ + at << ": bad .npy header: " << what
      << "; header: " << quoted(s_);
    throw InputError(m.str());
  }
  char peek() const { return i_ < s_.size() ? s_[i_] : '\0'; }
  void skip_ws() {
    while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t' || s_[i_] == '\n' || s_[i_] == '\r'))
      ++i_;
  }
  void expect(char c) {
    if (peek() != c) fail(i_, std::string("expected '") + c + "'");
    ++i_;
  }
  std::string string_value() {
    const char q = peek();
    if (q != '\'' && q != '"') fail(i_, "expected a quoted string");
    const std::size_t start = ++i_;
    while (i_ < s_.size() && s_[i_] != q) {
      if (s_[i_] == '\\') fail(i_, "escapes in strings are not supported");
      ++i_;
    }
    if (i_ >= s_.size()) fail(start - 1, "unterminated string");
    return s_.substr(start, i_++ - start);
  }
  bool bool_value() {
    if (s_.compare(i_, 4, "True") == 0) {
      i_ += 4;
      return true;
    }
    if (s_.compare(i_, 5, "False") == 0) {
      i_ += 5;
      return false;
    }
    fail(i_, "expected True or False");
  }
  std::vector<std::size_t> tuple_value() {
    std::vector<std::size_t> v;
    expect('(');
    skip_ws();
    bool need_comma_for_single = true;
    while (peek() != ')') {
      const std::size_t at = i_;
      if (peek() < '0' || peek() > '9') fail(i_, "expected a non-negative integer in 'shape'");
      std::size_t n = 0;
      while (peek() >= '0' && peek() <= '9') {
        const std::size_t d = static_cast<std::size_t>(peek() - '0');
        if (n > (std::numeric_limits<std::size_t>::max() - d) / 10)
          fail(at, "dimension in 'shape' is too large");
        n = n * 10 + d;
        ++i_;
      }
      if (peek() == 'L') ++i_;  // Python 2 long literal
      v.push_back(n);
      if (v.size() > 32) fail(at, "more than 32 dimensions");
      skip_ws();
      if (peek() == ',') {
        ++i_;
        need_comma_for_single = false;
        skip_ws();
      } else if (peek() != ')') {
        fail(i_, "expected ',' or ')' in 'shape'");
      } else if (v.size() == 1 && need_comma_for_single) {
        fail(i_, "'(n)' is not a tuple; NumPy writes '(n,)'");
      }
    }
    ++i_;
    return v;
  }

  const std::string& s_;
  std::size_t base_;
  const std::string& where_;
  std::size_t i_ = 0;
};

bool dtype_from_descr(const std::string& d, DType& t, bool& big_endian) {
  if (d.size() != 3) return false;
  const char order = d[0];
  const std::string kind = d.substr(1);
  if (kind == "u1") {
    if (order != '|' && order != '<' && order != '>') return false;
    t = DType::u1;
    big_endian = false;
    return true;
  }
  if (order != '<' && order != '>') return false;
  big_endian = order == '>';
  if (kind == "f4")
    t = DType::f4;
  else if (kind == "f8")
    t = DType::f8;
  else if (kind == "i4")
    t = DType::i4;
  else if (kind == "i8")
    t = DType::i8;
  else
    return false;
  return true;
}

}  // namespace

std::size_t item_size(DType t) {
  switch (t) {
    case DType::f4:
    case DType::i4:
      return 4;
    case DType::f8:
    case DType::i8:
      return 8;
    case DType::u1:
      return 1;
  }
  return 0;
}

const char* descr(DType t) {
  switch (t) {
    case DType::f4:
      return "<f4";
    case DType::f8:
      return "<f8";
    case DType::u1:
      return "|u1";
    case DType::i4:
      return "<i4";
    case DType::i8:
      return "<i8";
  }
  return "?";
}

std::size_t Array::count() const {
  std::size_t n = 1;
  for (std::size_t s : shape) n *= s;
  return n;
}

std::string Array::shape_string() const {
  std::ostringstream s;
  s << "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s << (i ? ", " : "") << shape[i];
  if (shape.size() == 1) s << ",";
  s << ")";
  return s.str();
}

std::vector<double> Array::to_double() const {
  const std::size_t n = count();
  const std::size_t w = item_size(dtype);
  if (data.size() != n * w) throw Error("npy::Array: data size does not match shape");
  std::vector<double> out(n);
  const unsigned char* p = data.data();
  for (std::size_t i = 0; i < n; ++i, p += w) {
    const std::uint64_t bits = load_le(p, w);
    switch (dtype) {
      case DType::f4: {
        const std::uint32_t b32 = static_cast<std::uint32_t>(bits);
        float f;
        std::memcpy(&f, &b32, 4);
        out[i] = f;
        break;
      }
      case DType::f8: {
        double d;
        std::memcpy(&d, &bits, 8);
        out[i] = d;
        break;
      }
      case DType::u1:
        out[i] = static_cast<double>(bits);
        break;
      case DType::i4:
        out[i] = static_cast<double>(static_cast<std::int32_t>(static_cast<std::uint32_t>(bits)));
        break;
      case DType::i8:
        out[i] = static_cast<double>(static_cast<std::int64_t>(bits));
        break;
    }
  }
  return out;
}

namespace {

// An array of `v` as little-endian bits of type Bits (the same size as T), `name` in errors.
template <class Bits, class T>
Array from_values(const std::vector<T>& v, std::vector<std::size_t> shape, DType dtype,
                  const char* name) {
  static_assert(sizeof(Bits) == sizeof(T), "bits of one value");
  Array a;
  a.dtype = dtype;
  a.shape = std::move(shape);
  if (a.count() != v.size())
    throw Error(std::string("npy::Array::") + name + ": shape does not match size");
  a.data.resize(v.size() * sizeof(T));
  for (std::size_t i = 0; i < v.size(); ++i) {
    Bits b;
    std::memcpy(&b, &v[i], sizeof(T));
    store_le(&a.data[i * sizeof(T)], b, sizeof(T));
  }
  return a;
}

}  // namespace

Array Array::from_doubles(const std::vector<double>& v, std::vector<std::size_t> shape) {
  return from_values<std::uint64_t>(v, std::move(shape), DType::f8, "from_doubles");
}

Array Array::from_floats(const std::vector<float>& v, std::vector<std::size_t> shape) {
  return from_values<std::uint32_t>(v, std::move(shape), DType::f4, "from_floats");
}

Header parse_header(const void* bytes, std::size_t size, const std::string& where) {
  const auto* b = static_cast<const unsigned char*>(bytes);
  auto fail = [&](std::size_t at, const std::string& what) {
    std::ostringstream m;
    m << where << ": byte offset " << at << ": " << what;
    throw InputError(m.str());
  };
  if (size < 8) {
    fail(size, "truncated: " + std::to_string(size) +
                   " bytes, a .npy array starts with 8 bytes of magic and version");
  }
  if (std::memcmp(b, kMagic, 6) != 0) {
    char hex[40];
    std::snprintf(hex, sizeof hex, "%02x %02x %02x %02x %02x %02x", b[0], b[1], b[2], b[3], b[4],
                  b[5]);
    fail(0, std::string("not a .npy array: magic bytes are ") + hex +
                " (expected 93 4e 55 4d 50 59, \"\\x93NUMPY\")");
  }
  const int major = b[6], minor = b[7];
  if (major < 1 || major > 3 || minor != 0)
    fail(6, "unsupported .npy format version " + std::to_string(major) + "." +
                std::to_string(minor) + " (supported: 1.0, 2.0, 3.0)");
  const std::size_t len_bytes = major == 1 ? 2 : 4;
  if (size < 8 + len_bytes) fail(8, "truncated inside the header length field");
  const std::size_t header_len = static_cast<std::size_t>(load_le(b + 8, len_bytes));
  const std::size_t start = 8 + len_bytes;
  if (header_len > size - start)
    fail(start, "truncated: header of " + std::to_string(header_len) +
                    " bytes runs past the end of the data (" + std::to_string(size) + " bytes)");
  std::string text(reinterpret_cast<const char*>(b + start), header_len);
  if (major < 3) {
    for (std::size_t i = 0; i < text.size(); ++i)
      if (static_cast<unsigned char>(text[i]) >= 128)
        fail(start + i, "non-ASCII byte in a version " + std::to_string(major) + " header");
  }
  std::string d;
  Header h;
  HeaderParser(text, start, where).parse(d, h.fortran_order, h.shape);
  if (!dtype_from_descr(d, h.dtype, h.big_endian))
    fail(start, "unsupported dtype " + quoted(d) +
                    " (supported: '<f4', '<f8', '|u1', '<i4', '<i8' and big-endian forms)");
  h.data_offset = start + header_len;
  std::size_t n = 1;
  for (std::size_t s : h.shape)
    if (mul_overflows(n, s, n)) fail(start, "shape is too large");
  if (mul_overflows(n, item_size(h.dtype), h.data_bytes)) fail(start, "shape is too large");
  return h;
}

Array parse(const void* bytes, std::size_t size, const std::string& where) {
  const Header h = parse_header(bytes, size, where);
  Array a;
  a.dtype = h.dtype;
  a.shape = h.shape;
  const std::size_t w = item_size(a.dtype);
  const std::size_t n = a.count();
  const std::size_t nbytes = h.data_bytes;
  const std::size_t have = size - h.data_offset;
  if (have != nbytes) {
    std::ostringstream m;
    m << where << ": byte offset " << h.data_offset << ": shape " << a.shape_string() << " of "
      << descr(a.dtype) << " needs " << nbytes << " data bytes, "
      << (have < nbytes ? "but only " : "but there are ") << have
      << (have < nbytes ? " remain (truncated)" : " (unexpected trailing bytes)");
    throw InputError(m.str());
  }
  const auto* src = static_cast<const unsigned char*>(bytes) + h.data_offset;
  a.data.assign(src, src + nbytes);
  if (h.big_endian && w > 1)
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t k = 0; k < w / 2; ++k)
        std::swap(a.data[i * w + k], a.data[i * w + w - 1 - k]);
  if (h.fortran_order && a.shape.size() > 1) {
    // Walk the C-order multi-index and fetch each element from its Fortran-order position.
    const std::size_t nd = a.shape.size();
    std::vector<std::size_t> fstride(nd), idx(nd, 0);
    std::size_t st = 1;
    for (std::size_t d = 0; d < nd; ++d) {
      fstride[d] = st;
      st *= a.shape[d];
    }
    std::vector<unsigned char> c(nbytes);
    for (std::size_t i = 0; i < n; ++i) {
      std::size_t f = 0;
      for (std::size_t d = 0; d < nd; ++d) f += idx[d] * fstride[d];
      std::memcpy(&c[i * w], &a.data[f * w], w);
      for (std::size_t d = nd; d-- > 0;) {
        if (++idx[d] < a.shape[d]) break;
        idx[d] = 0;
      }
    }
    a.data.swap(c);
  }
  return a;
}

std::string serialize(const Array& a) {
  if (a.data.size() != a.count() * item_size(a.dtype))
    throw Error("npy::serialize: data size does not match shape " + a.shape_string());
  std::string header = std::string("{'descr': '") + descr(a.dtype) +
                       "', 'fortran_order': False, 'shape': " + a.shape_string() + ", }";
  // NumPy pads the header with spaces and ends it with '\n' so the data starts 64-byte aligned.
  std::size_t prefix = 10;
  std::size_t total = prefix + header.size() + 1;
  int major = 1;
  if (total + 64 > 65535 + prefix) {
    major = 2;
    prefix = 12;
    total = prefix + header.size() + 1;
  }
  header.append((64 - total % 64) % 64, ' ');
  header += '\n';
  std::string out(reinterpret_cast<const char*>(kMagic), 6);
  out += static_cast<char>(major);
  out += '\0';
  unsigned char len[4];
  store_le(len, header.size(), prefix - 8);
  out.append(reinterpret_cast<const char*>(len), prefix - 8);
  out += header;
  out.append(reinterpret_cast<const char*>(a.data.data()), a.data.size());
  return out;
}

Array read_file(const std::string& path) {
  const std::string bytes = detail::read_whole_file(path);
  return parse(bytes.data(), bytes.size(), path);
}

void write_file(const Array& a, const std::string& path) {
  detail::write_file_atomically(path, serialize(a));
}

}  // namespace potmap::npy
