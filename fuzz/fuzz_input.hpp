#pragma once
// The readers take paths: each fuzz input is written to a per-process temporary file.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>

namespace potmap::fuzz {
inline std::string write_input(const uint8_t* data, size_t size, const char* suffix) {
  const std::string path =
      "/tmp/potmap-fuzz-" + std::to_string(static_cast<long>(getpid())) + suffix;
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return path;
  std::fwrite(data, 1, size, f);
  std::fclose(f);
  return path;
}
}  // namespace potmap::fuzz
