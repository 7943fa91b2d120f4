#pragma once
// Reading and writing kernel maps.
//
// Formats, chosen by file extension:
//   .csv     header `x,y,gamma,w_mean,w_var` (2D) or `x,y,z,gamma,w_mean,w_var` (3D); columns in
//            any order, extra columns ignored; an optional last row with `bias` ... is not used:
//            the bias weight is stored in a comment line `# bias w_mean w_var`.
//   .npz     NumPy archive as the paper's authors saved maps: `qhinge_mean` (M,D) positions,
//            `qgamma_mean_forward` (1,M) or (M,) widths, `qw_mean` (M,1) weight means,
//            `qw_var` (M,1) weight variances; optional `bias_mean`, `bias_var` scalars.
//   .potmap  native binary: versioned header, dimension, count, payload, CRC-32 checksum.
//
// Errors are potmap::InputError naming the file, the line (text) or byte offset (binary) and
// the offending value. Writers write to a temporary file in the same folder and rename it, so
// an existing file is never left half-written.

#include <string>

#include "potmap/kernel_map.hpp"

namespace potmap {

/// Reads a map, format from the extension (.csv, .npz, .potmap; also .csv.gz is not supported).
KernelMap read_map(const std::string& path);
/// Writes a map, format from the extension (.csv, .npz, .potmap).
void write_map(const KernelMap& map, const std::string& path);

KernelMap read_map_csv(const std::string& path);
void write_map_csv(const KernelMap& map, const std::string& path);
KernelMap read_map_npz(const std::string& path);
void write_map_npz(const KernelMap& map, const std::string& path);
KernelMap read_map_native(const std::string& path);
void write_map_native(const KernelMap& map, const std::string& path);

}  // namespace potmap
