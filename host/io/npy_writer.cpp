#include "io/npy_writer.hpp"

#include <cstdint>
#include <cstring>
#include <vector>

#include "io/le_bytes.hpp"
#include "potmap/error.hpp"

namespace potmap::detail {

std::string NpyWriter::header(std::size_t rows, std::size_t cols) {
  std::string dict = "{'descr': '<f4', 'fortran_order': False, 'shape': (" + std::to_string(rows) +
                     ", " + std::to_string(cols) + "), }";
  // NumPy aligns the data to 64 bytes (format 1.0 allows any multiple of 16; 64 suits mmap).
  const std::size_t prefix = 10;  // magic (6) + version (2) + header length (2)
  std::size_t total = prefix + dict.size() + 1;
  const std::size_t padded = (total + 63) / 64 * 64;
  dict.append(padded - total, ' ');
  dict.push_back('\n');
  const std::size_t hlen = dict.size();
  if (hlen > 65535) throw ArgumentError("npy header too long");
  std::string h = "\x93NUMPY";
  h.push_back('\x01');
  h.push_back('\x00');
  h.push_back(static_cast<char>(hlen & 0xff));
  h.push_back(static_cast<char>(hlen >> 8));
  return h + dict;
}

NpyWriter::NpyWriter(const std::string& path, std::size_t rows, std::size_t cols)
    : out_(path), rows_(rows), cols_(cols) {
  const std::string h = header(rows, cols);
  out_.write(h.data(), h.size());
}

void NpyWriter::write_row(const float* values) {
  if (written_ >= rows_) {
    out_.discard();
    throw Error("cannot write " + out_.path() + ": more rows than the array shape");
  }
  try {
    if (host_is_little_endian()) {
      out_.write(values, cols_ * sizeof(float));
    } else {
      std::vector<unsigned char> buf(cols_ * 4);
      for (std::size_t i = 0; i < cols_; ++i) {
        std::uint32_t u;
        std::memcpy(&u, values + i, 4);
        for (int k = 0; k < 4; ++k) buf[i * 4 + k] = static_cast<unsigned char>(u >> (8 * k));
      }
      out_.write(buf.data(), buf.size());
    }
  } catch (...) {
    out_.discard();
    throw;
  }
  ++written_;
}

void NpyWriter::complete() {
  if (written_ != rows_) {
    out_.discard();
    throw Error("cannot write " + out_.path() + ": only " + std::to_string(written_) + " of " +
                std::to_string(rows_) + " rows written");
  }
  out_.sync();
}

void NpyWriter::finish() {
  complete();
  out_.commit();
}

}  // namespace potmap::detail
