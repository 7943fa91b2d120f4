#pragma once
// Reading and writing kernel maps.
//
// Formats, chosen by file extension (case-insensitive):
//   .csv     header `x,y,gamma,w_mean,w_var` (2D) or `x,y,z,gamma,w_mean,w_var` (3D); columns
//            found by name (case-insensitive) in any order, extra columns ignored, the dimension
//            follows from the presence of `z`. Lines starting with `#` are comments; the bias
//            weight, if any, is the comment `# bias <w_mean> <w_var>` and the map's own cut-off
//            (KernelMap::cutoff_tau), if any, `# cutoff <tau>` (anywhere, each at most once).
//            Blank lines are skipped. Numbers are written as the shortest text that reads back
//            to the same double (exact round trip) and parsed independently of the C locale.
//   .npz     NumPy archive as the paper's authors saved maps: `qhinge_mean` (M,D) positions,
//            `qgamma_mean_forward` (1,M), (M,) or (M,1) widths, `qw_mean` and `qw_var` (M,1),
//            (M,) or (1,M) weight means and variances; optional `bias_mean` and `bias_var`
//            single values (both or neither), optional `cutoff_tau` single value. Any of
//            float32/float64 (also int) is read; float64 is written, uncompressed, in the same
//            layout (qgamma as (1,M)).
//   .potmap  native binary, all integers and doubles little-endian:
//              offset  0: magic "POTMAP\r\n" (8 bytes)
//                      8: uint32 format version (1)
//                     12: uint32 dimension D (2 or 3)
//                     16: uint64 kernel count M
//                     24: uint32 flags (bit 0: has bias), 28: uint32 reserved (0)
//                     32: float64 bias mean, 40: float64 bias variance (0 when no bias)
//                     48: float64 positions (M*D, row-major), then gamma (M), w_mean (M),
//                         w_var (M)
//              48 + 8*M*(D+3): uint32 CRC-32 (zlib crc32) of every byte before it.
//            Format version 2 (a joint BHM's map with its information form, for merging:
//            potmap/learn/bhm_joint_merge.hpp) is version 1 with flags bit 1 set and, between
//            w_var and the CRC, a uint64 byte count S and S bytes of the learner's information
//            form. read_map() reads both versions (the map alone); write_map() writes version
//            1, which readers before version 2 still read. A map with its own cut-off
//            (KernelMap::cutoff_tau finite) is written as version 2 with flags bit 2 set and a
//            float64 cut-off exponent right after w_var (before the section, if any).
//
// Every reader checks the values as KernelMap::validate does (finite, gamma > 0, w_var >= 0),
// the dimension, field counts and array shapes, and every length read from a file against the
// file size before using it.
// Errors are potmap::InputError naming the file, the line (text) or byte offset (binary) and
// the offending value. Writers write to a temporary file in the same folder and rename it, so
// an existing file is never left half-written.

#include <string>

#include "potmap/error.hpp"  // InputError, ArgumentError: what these functions throw
#include "potmap/export.h"
#include "potmap/map/kernel_map.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// Reads a map, format from the extension (.csv, .npz, .potmap; compressed .gz is rejected).
/// Throws InputError for an unknown extension, an unreadable file or bad content.
KernelMap read_map(const std::string& path);
/// Writes a map, format from the extension (.csv, .npz, .potmap). Throws ArgumentError for an
/// unknown extension or a map that fails KernelMap::validate, potmap::Error if writing fails.
void write_map(const KernelMap& map, const std::string& path);

KernelMap read_map_csv(const std::string& path);
void write_map_csv(const KernelMap& map, const std::string& path);
KernelMap read_map_npz(const std::string& path);
void write_map_npz(const KernelMap& map, const std::string& path);
KernelMap read_map_native(const std::string& path);
void write_map_native(const KernelMap& map, const std::string& path);

}  // namespace potmap
POTMAP_CXX_API_END
