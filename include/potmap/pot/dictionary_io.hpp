#pragma once
// The dictionary file (.potdict): a Dictionary of atoms (atoms.hpp) in one binary file.
//
// All integers and doubles little-endian. Layout, version 1:
//   header, 64 bytes:
//      0: magic "POTDIC\r\n" (8 bytes)
//      8: uint32 format version (1)
//     12: uint32 dimension D (2 or 3)
//     16: float64 scale s (> 0)
//     24: float64 max_range, metres (> 0)
//     32: uint32 sectors (>= 1), 36: uint32 reserved (0)
//     40: uint64 atom count A
//     48: uint64 total file size in bytes (checked first: a truncated file is named as such)
//     56: uint64 reserved (0)
//   then A atom records, each:
//     +0: int32 sector index (in [0, sectors)), +4: uint32 reserved (0)
//     +8: float64 centre[3], +32: float64 sensor[3] (world frame, metres; z 0 in 2D)
//    +56: float64 scale (must equal the header's), +64: float64 max_range, metres (> 0)
//    +72: int64 scan index
//    +80: uint64 hits H, +88: uint64 free F, +96: uint64 kernels K
//   +104: uint32 source length L (bytes, <= 65536), +108: uint32 reserved (0)
//   +112: L bytes of source text (no terminator)
//         then float64: hits (H*D), free (F*D), kernel positions (K*D), gamma (K), w_mean (K),
//         w_var (K)
//   last 4 bytes: uint32 CRC-32 (zlib crc32) of every byte before it.
//
// The reader checks, in this order, the magic, the version, the dimension, the stored file
// size against the real one, the checksum, then every field: counts against the bytes left
// before using them, every double finite, gamma > 0, w_var >= 0, sector index in range, the
// atom's scale equal to the dictionary's. Errors are InputError naming the file, the byte
// offset and the value. Kernels of atoms have no bias (write_dictionary rejects one).

#include <string>
#include "potmap/export.h"

#include "potmap/error.hpp"  // InputError, ArgumentError: what these functions throw
#include "potmap/pot/atoms.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// Current format version written by write_dictionary.
inline constexpr unsigned kDictionaryFormatVersion = 1;

/// Throws ArgumentError naming the first atom and field that is inconsistent: dimension not 2
/// or 3, point or kernel arrays whose sizes disagree with dim, non-finite values, gamma <= 0,
/// w_var < 0, a bias on atom kernels, scale or max_range <= 0, sector index out of range, an
/// atom whose dim or scale differs from the dictionary's. `source` prefixes the message.
void validate_dictionary(const Dictionary& dict, const std::string& source = "");

/// Writes `dict` to `path` (any extension; .potdict by convention) through a temporary file and
/// a rename. Throws ArgumentError if validate_dictionary fails, potmap::Error if writing fails.
void write_dictionary(const Dictionary& dict, const std::string& path);

/// Reads a dictionary written by write_dictionary. Throws InputError (file, byte offset, value)
/// for an unreadable, truncated, corrupt or inconsistent file.
Dictionary read_dictionary(const std::string& path);

}  // namespace potmap
POTMAP_CXX_API_END
