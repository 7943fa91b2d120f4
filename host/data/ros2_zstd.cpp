// zstd's streaming decompressor, for rosbag2's FILE and MESSAGE compression modes.
#include "data/ros2_zstd.hpp"

#include <unistd.h>
#include <zstd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>

#include "potmap/error.hpp"

namespace potmap::data {

namespace {

struct DCtxFree {
  void operator()(ZSTD_DCtx* c) const { ZSTD_freeDCtx(c); }
};
struct FileClose {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using DCtx = std::unique_ptr<ZSTD_DCtx, DCtxFree>;
using File = std::unique_ptr<std::FILE, FileClose>;

DCtx new_dctx() {
  DCtx c(ZSTD_createDCtx());
  if (!c) throw std::bad_alloc();
  return c;
}

}  // namespace

TempFile::TempFile(const std::string& stem) {
  std::string name =
      (std::filesystem::temp_directory_path() / ("potmap-" + stem + "-XXXXXX")).string();
  // The copy of a bag's file is only ever read by this process: mkstemp's 0600 suits it.
  const int fd = ::mkstemp(name.data());
  if (fd < 0)
    throw InputError(name + ": cannot create a temporary file for a decompressed bag file (" +
                     std::strerror(errno) + ")");
  ::close(fd);
  path_ = name;
}

TempFile::~TempFile() {
  std::remove(path_.c_str());
}

void zstd_decompress_file(const std::string& from, const std::string& to) {
  File in(std::fopen(from.c_str(), "rb"));
  if (!in) throw InputError(from + ": cannot open (" + std::strerror(errno) + ")");
  File out(std::fopen(to.c_str(), "wb"));
  if (!out) throw InputError(to + ": cannot write (" + std::strerror(errno) + ")");
  DCtx dctx = new_dctx();
  std::vector<char> ibuf(ZSTD_DStreamInSize()), obuf(ZSTD_DStreamOutSize());
  std::size_t last = 0, read_total = 0;
  while (const std::size_t got = std::fread(ibuf.data(), 1, ibuf.size(), in.get())) {
    ZSTD_inBuffer input{ibuf.data(), got, 0};
    for (bool full = true; input.pos < input.size || full;) {
      ZSTD_outBuffer output{obuf.data(), obuf.size(), 0};
      last = ZSTD_decompressStream(dctx.get(), &output, &input);
      if (ZSTD_isError(last))
        throw InputError(from + ": byte " + std::to_string(read_total + input.pos) +
                         ": not a readable zstd file (" + ZSTD_getErrorName(last) + ")");
      if (std::fwrite(obuf.data(), 1, output.pos, out.get()) != output.pos)
        throw InputError(to + ": writing the decompressed bag file failed (" +
                         std::strerror(errno) + ")");
      full = output.pos == output.size;  // the decoder may hold more of this input
    }
    read_total += got;
  }
  if (read_total == 0) throw InputError(from + ": empty file, not zstd");
  if (last != 0)
    throw InputError(from + ": the zstd stream is cut short after " + std::to_string(read_total) +
                     " bytes");
  if (std::fflush(out.get()) != 0)
    throw InputError(to + ": writing the decompressed bag file failed (" + std::strerror(errno) +
                     ")");
}

std::vector<std::uint8_t> zstd_decompress(const std::uint8_t* data, std::size_t size,
                                          const std::string& where) {
  DCtx dctx = new_dctx();
  std::vector<std::uint8_t> out;
  // Grown as output appears rather than sized by the frame's header, which corrupt data could
  // make claim gigabytes.
  const std::size_t chunk = ZSTD_DStreamOutSize();
  ZSTD_inBuffer input{data, size, 0};
  for (;;) {
    const std::size_t had = out.size();
    out.resize(had + chunk);
    ZSTD_outBuffer output{out.data() + had, chunk, 0};
    const std::size_t left = ZSTD_decompressStream(dctx.get(), &output, &input);
    out.resize(had + output.pos);
    if (ZSTD_isError(left))
      throw InputError(where + ": byte " + std::to_string(input.pos) +
                       ": message is not readable zstd (" + ZSTD_getErrorName(left) + ")");
    if (input.pos < input.size || output.pos == chunk) continue;  // more frames, or to flush
    if (left == 0) break;
    throw InputError(where + ": zstd message of " + std::to_string(size) + " bytes is cut short");
  }
  return out;
}

}  // namespace potmap::data
