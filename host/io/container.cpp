#include "io/container.hpp"

#include <cstdio>
#include <cstring>

#include "io/file_util.hpp"
#include "io/text_io.hpp"
#include "potmap/error.hpp"

namespace potmap::detail {

namespace {
constexpr std::size_t kMagicBytes = 8;
constexpr std::size_t kCrcBytes = 4;
}  // namespace

ContainerWriter::ContainerWriter(const ContainerLayout& layout, std::size_t expected_bytes)
    : layout_(layout) {
  out_.reserve(expected_bytes);
  out_.assign(layout.magic.data(), kMagicBytes);
  put_u32(out_, layout.version);
}

void ContainerWriter::patch_u64(std::size_t at, std::uint64_t v) {
  std::string b;
  put_u64(b, v);
  out_.replace(at, 8, b);
}

std::uint32_t ContainerWriter::finish(const std::string& path) {
  const std::string bytes = finish_bytes();
  write_file_atomically(path, bytes);
  return static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[bytes.size() - 4])) |
         static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[bytes.size() - 3])) << 8 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[bytes.size() - 2])) << 16 |
         static_cast<std::uint32_t>(static_cast<unsigned char>(bytes[bytes.size() - 1])) << 24;
}

std::string ContainerWriter::finish_bytes() {
  if (layout_.size_field != ContainerLayout::kNoSizeField) {
    std::string total;
    put_u64(total, out_.size() + kCrcBytes);
    out_.replace(layout_.size_field, 8, total);
  }
  const std::uint32_t crc =
      crc32_of(reinterpret_cast<const unsigned char*>(out_.data()), out_.size());
  put_u32(out_, crc);
  return std::move(out_);
}

ContainerReader::ContainerReader(const std::string& path, const ContainerLayout& layout)
    : path_(path), layout_(layout), bytes_(read_whole_file(path)) {
  b_ = reinterpret_cast<const unsigned char*>(bytes_.data());
  const std::size_t n = bytes_.size();
  const std::string_view magic = layout.magic.substr(0, kMagicBytes);
  if (n < kMagicBytes && std::memcmp(b_, magic.data(), n) == 0)
    fail(n, "truncated: " + std::to_string(n) + " bytes");
  if (n < kMagicBytes || std::memcmp(b_, magic.data(), kMagicBytes) != 0)
    fail(0, "not " + std::string(layout.kind) + ": magic " +
                quote_value(std::string_view(bytes_).substr(0, kMagicBytes)) + " (expected " +
                quote_value(magic) + ")");
  if (n < kMagicBytes + 4) fail(n, "truncated: " + std::to_string(n) + " bytes, no version field");
  const std::uint32_t version = u32(kMagicBytes);
  const std::uint32_t oldest = layout.oldest_version ? layout.oldest_version : layout.version;
  if (version < oldest || version > layout.version)
    fail(kMagicBytes, "unsupported format version " + std::to_string(version) +
                          " (this build reads version " +
                          (oldest == layout.version
                               ? std::to_string(layout.version)
                               : std::to_string(oldest) + " to " + std::to_string(layout.version)) +
                          ")");
  if (n < layout.header_bytes + kCrcBytes)
    fail(n, "truncated: " + std::to_string(n) + " bytes, the header alone needs " +
                std::to_string(layout.header_bytes + kCrcBytes));
}

void ContainerReader::fail(std::size_t offset, const std::string& what) const {
  throw InputError(path_ + ": byte offset " + std::to_string(offset) + ": " + what);
}

void ContainerReader::check_size(std::uint64_t expected, std::size_t field_at,
                                 const std::string& what) const {
  const std::size_t n = size();
  if (expected == n) return;
  fail(field_at,
       what + " " + (expected ? std::to_string(expected) : std::string("more than 2^64")) +
           " bytes, the file has " + std::to_string(n) +
           (expected > n || !expected ? " (truncated)" : " (trailing bytes or corrupt header)"));
}

void ContainerReader::check_checksum() const {
  const std::size_t crc_at = payload_end();
  const std::uint32_t stored = u32(crc_at);
  const std::uint32_t actual = crc32_of(b_, crc_at);
  if (stored == actual) return;
  char m[128];
  std::snprintf(m, sizeof m, "checksum mismatch: stored CRC-32 %08x, computed %08x (corrupt file)",
                stored, actual);
  fail(crc_at, m);
}

void ContainerReader::verify() const {
  check_size(u64(layout_.size_field), layout_.size_field, "the header gives a file size of");
  check_checksum();
}

}  // namespace potmap::detail
