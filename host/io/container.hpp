#pragma once
// The container shared by every native binary file (.potmap maps, .potdict dictionaries, ABHM
// checkpoints and parameter files):
//
//   offset 0   8 bytes  magic
//   offset 8   u32      format version
//   ...                 the format's own header fields and payload, little-endian
//   size - 4   u32      CRC-32 (zlib) of every byte before it
//
// The whole file size is either stored as a u64 in the header (`ContainerLayout::size_field`)
// or derived by the format from its header (ContainerReader::check_size). Files are written
// atomically. Every read error is an InputError "<path>: byte offset <n>: <what>", naming the
// value found where it is wrong.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "io/le_bytes.hpp"

namespace potmap::detail {

struct ContainerLayout {
  static constexpr std::size_t kNoSizeField = static_cast<std::size_t>(-1);
  std::string_view magic;    ///< 8 bytes
  std::string_view kind;     ///< what the file is, for "not <kind>" ("a potmap map")
  std::uint32_t version;     ///< the version this build writes and reads
  std::size_t header_bytes;  ///< the fixed header, magic included (the CRC trailer comes on top)
  /// Offset of a u64 holding the whole file size, or kNoSizeField when the format derives the
  /// size from its header fields.
  std::size_t size_field = kNoSizeField;
  /// The oldest version the reader takes as well (0: `version` alone); the format tells the
  /// versions apart by ContainerReader::version().
  std::uint32_t oldest_version = 0;
};

/// Builds a container in memory: magic and version first, then whatever the format puts, then
/// finish() fills the size field, appends the CRC-32 and writes the file atomically.
class ContainerWriter {
 public:
  explicit ContainerWriter(const ContainerLayout& layout, std::size_t expected_bytes = 0);
  void u32(std::uint32_t v) { put_u32(out_, v); }
  void u64(std::uint64_t v) { put_u64(out_, v); }
  void f64(double v) { put_f64(out_, v); }
  template <class Range>
  void f64s(const Range& values) {
    for (double v : values) put_f64(out_, v);
  }
  void f32s(const std::vector<float>& values) { put_f32s(out_, values.data(), values.size()); }
  void bytes(std::string_view s) { out_ += s; }
  std::size_t size() const { return out_.size(); }
  /// Overwrites the u64 at `at` (a length known only once what follows it is written).
  void patch_u64(std::size_t at, std::uint64_t v);
  /// Writes the file; returns its CRC-32 (the trailer), so that a caller keeping a record of
  /// the file need not read it back.
  std::uint32_t finish(const std::string& path);
  /// The file's bytes (size field and CRC trailer filled in) instead of the file: a caller
  /// writes them later, on another thread. The writer is then empty.
  std::string finish_bytes();

 private:
  const ContainerLayout& layout_;
  std::string out_;
};

/// Reads a whole container file. The constructor checks the magic, the version and that the
/// fixed header and the checksum are there; the format then checks the header fields the size
/// depends on and calls check_size() (or verify()) and check_checksum() before trusting them.
class ContainerReader {
 public:
  ContainerReader(const std::string& path, const ContainerLayout& layout);

  const std::string& path() const { return path_; }
  std::uint32_t version() const { return u32(8); }
  const unsigned char* data() const { return b_; }
  std::size_t size() const { return bytes_.size(); }
  /// Where the checksum starts: the end of the payload.
  std::size_t payload_end() const { return size() - 4; }
  std::uint64_t uint(std::size_t at, int n) const { return get_le(b_ + at, n); }
  std::uint32_t u32(std::size_t at) const { return static_cast<std::uint32_t>(uint(at, 4)); }
  std::uint64_t u64(std::size_t at) const { return uint(at, 8); }
  double f64(std::size_t at) const { return get_f64(b_ + at); }
  float f32(std::size_t at) const { return get_f32(b_ + at); }

  /// Throws InputError "<path>: byte offset <offset>: <what>".
  [[noreturn]] void fail(std::size_t offset, const std::string& what) const;
  /// The file must have `expected` bytes (0: more than 2^64), as `what` (the header fields at
  /// `field_at` that give it, "... needs a file of") says.
  void check_size(std::uint64_t expected, std::size_t field_at, const std::string& what) const;
  /// The CRC-32 trailer must match the bytes before it.
  void check_checksum() const;
  /// For layouts with a size field: check_size() against it, then check_checksum().
  void verify() const;

 private:
  std::string path_;
  const ContainerLayout& layout_;
  std::string bytes_;
  const unsigned char* b_;
};

}  // namespace potmap::detail
