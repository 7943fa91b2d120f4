#pragma once
// NumPy .npy arrays (format versions 1.0, 2.0 and 3.0): a strict reader and a writer, for maps
// (map_io_npz.cpp) and for anything else that exchanges arrays with Python.
//
// Accepted element types: '<f4', '<f8', '|u1', '<i4', '<i8' (and the big-endian forms '>f4',
// '>f8', '>i4', '>i8', converted on reading). Both memory orders are read; parse() always
// returns C (row-major) order. Anything else (object or structured dtypes, unknown header keys,
// element counts that disagree with the byte count) is rejected with an InputError whose
// message starts with the `where` label given by the caller (e.g. "map.npz: qw_mean.npy").

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace potmap::npy {

enum class DType { f4, f8, u1, i4, i8 };

/// Size of one element in bytes.
std::size_t item_size(DType t);
/// NumPy's little-endian descriptor: "<f4", "<f8", "|u1", "<i4", "<i8".
const char* descr(DType t);

/// An n-dimensional array. `data` holds the elements in C order, little-endian.
struct Array {
  DType dtype = DType::f8;
  std::vector<std::size_t> shape;  ///< empty for a 0-d (scalar) array
  std::vector<unsigned char> data;

  /// Number of elements: the product of shape (1 for a scalar).
  std::size_t count() const;
  /// All elements converted to double, C order.
  std::vector<double> to_double() const;
  /// "(3, 2)" as Python prints the shape.
  std::string shape_string() const;

  static Array from_doubles(const std::vector<double>& v, std::vector<std::size_t> shape);
  static Array from_floats(const std::vector<float>& v, std::vector<std::size_t> shape);
};

/// Parses a complete .npy file image. `where` prefixes error messages. Offsets in messages are
/// bytes from the start of `bytes`.
Array parse(const void* bytes, std::size_t size, const std::string& where);
/// What the header of a .npy image says.
struct Header {
  DType dtype = DType::f8;
  std::vector<std::size_t> shape;
  bool fortran_order = false;
  bool big_endian = false;
  std::size_t data_offset = 0;  ///< bytes from the start of the image to the first element
  std::size_t data_bytes = 0;   ///< bytes of element data the shape and dtype call for
};
/// Parses only the header; `bytes` may be just the start of the image (at least the header).
Header parse_header(const void* bytes, std::size_t size, const std::string& where);
/// The .npy image of an array (version 1.0 header, padded to 64 bytes as NumPy does).
std::string serialize(const Array& a);

/// Reads a .npy file (errors name the path).
Array read_file(const std::string& path);
/// Writes a .npy file atomically.
void write_file(const Array& a, const std::string& path);

}  // namespace potmap::npy
