#pragma once
// Sequential reads of a container's payload (io/container.hpp) for formats whose sections have
// variable lengths (mapper states, map checkpoints): every read checks that the bytes are there
// before the checksum, so a count that does not match the payload is an InputError
// "<path>: byte offset <n>: ..." naming the count, never a read past the end.

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "io/container.hpp"

namespace potmap::detail {

class ContainerCursor {
 public:
  ContainerCursor(const ContainerReader& r, std::size_t at) : r_(r), at_(at) {}
  std::size_t at() const { return at_; }
  const ContainerReader& reader() const { return r_; }

  std::uint8_t u8() { return static_cast<std::uint8_t>(r_.uint(take(1, "a byte"), 1)); }
  std::uint32_t u32() { return r_.u32(take(4, "a u32")); }
  std::uint64_t u64() { return r_.u64(take(8, "a u64")); }
  double f64() { return r_.f64(take(8, "a double")); }
  /// A u64 count, then that many values of `bytes_each` bytes: the count must fit the payload.
  std::size_t count(std::size_t bytes_each, const char* what) {
    const std::size_t field = at_;
    const std::uint64_t n = u64();
    if (n > (r_.payload_end() - at_) / bytes_each)
      r_.fail(field, std::string(what) + ": count " + std::to_string(n) + " needs " +
                         (n > (std::uint64_t(1) << 60) ? std::string("more than 2^60")
                                                       : std::to_string(n * bytes_each)) +
                         " bytes, " + std::to_string(r_.payload_end() - at_) + " are left");
    return static_cast<std::size_t>(n);
  }
  /// `n` floats (little-endian, no count before them: ContainerWriter::f32s).
  std::vector<float> f32s(std::size_t n, const char* what) {
    if (n > (r_.payload_end() - at_) / 4)
      r_.fail(at_, std::string(what) + ": " + std::to_string(n) + " floats need " +
                       std::to_string(4 * n) + " bytes, " + std::to_string(r_.payload_end() - at_) +
                       " are left");
    std::vector<float> v(n);
    for (float& x : v) {
      const std::uint32_t bits = u32();
      std::memcpy(&x, &bits, sizeof x);
    }
    return v;
  }
  std::vector<double> f64s(const char* what) {
    std::vector<double> v(count(8, what));
    for (double& x : v) x = f64();
    return v;
  }
  template <class T>
  std::vector<T> uints(const char* what) {
    std::vector<T> v(count(sizeof(T), what));
    for (T& x : v) x = static_cast<T>(r_.uint(take(sizeof(T), what), int(sizeof(T))));
    return v;
  }
  std::string text(const char* what) {
    const std::size_t n = count(1, what);
    std::string s(reinterpret_cast<const char*>(r_.data()) + at_, n);
    at_ += n;
    return s;
  }
  /// The payload must end here.
  void finish() const {
    if (at_ != r_.payload_end())
      r_.fail(at_, std::to_string(r_.payload_end() - at_) + " unread bytes before the checksum");
  }

 private:
  // The offset of the next n bytes, which are then consumed.
  std::size_t take(std::size_t n, const char* what) {
    if (r_.payload_end() - at_ < n)
      r_.fail(at_, std::string("truncated: ") + what + " needs " + std::to_string(n) + " bytes, " +
                       std::to_string(r_.payload_end() - at_) + " are left");
    at_ += n;
    return at_ - n;
  }
  const ContainerReader& r_;
  std::size_t at_;
};

/// Reads an f64 that must equal `have` bit for bit (an option a saved state was made with);
/// fails naming `who`, `what`, the value found and the one expected.
inline void expect_same_f64(ContainerCursor& c, const char* who, const char* what, double have) {
  const std::size_t at = c.at();
  const double found = c.f64();
  if (std::memcmp(&found, &have, sizeof found) != 0)
    c.reader().fail(at, std::string(who) + ": " + what + " " + std::to_string(found) +
                            ", the map it is restored into has " + std::to_string(have));
}

/// Writes what ContainerCursor reads: a u64 count, then the values.
inline void put_f64s(ContainerWriter& w, const std::vector<double>& v) {
  w.u64(v.size());
  w.f64s(v);
}
template <class T>
void put_uints(ContainerWriter& w, const std::vector<T>& v) {
  w.u64(v.size());
  std::string b;
  b.reserve(v.size() * sizeof(T));
  for (T x : v)
    for (std::size_t i = 0; i < sizeof(T); ++i)
      b += static_cast<char>((std::uint64_t(x) >> (8 * i)) & 0xff);
  w.bytes(b);
}
inline void put_u8(ContainerWriter& w, std::uint8_t v) {
  w.bytes(std::string(1, static_cast<char>(v)));
}
inline void put_text(ContainerWriter& w, const std::string& s) {
  w.u64(s.size());
  w.bytes(s);
}

}  // namespace potmap::detail
