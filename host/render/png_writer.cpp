#include "render/png_writer.hpp"

#include <png.h>
#include <zlib.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>

#include "io/atomic_file.hpp"
#include "potmap/error.hpp"

namespace potmap::detail {

namespace {

// libpng reports errors by longjmp. Every libpng call is made inside one of the small functions
// below, which hold no C++ object with a destructor, so the jump never skips one; they return
// false and the caller throws with the message libpng left in the state.
struct PngState {
  char message[256] = {0};
};

void on_error(png_structp png, png_const_charp msg) {
  auto* st = static_cast<PngState*>(png_get_error_ptr(png));
  std::snprintf(st->message, sizeof st->message, "%s", msg ? msg : "libpng error");
  png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}

// `palette`: null for RGB, else `colours` entries of an indexed picture. The compression
// settings are explained in png_writer.hpp.
bool start(png_structp png, png_infop info, std::FILE* f, png_uint_32 w, png_uint_32 h,
           const png_color* palette, int colours) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_init_io(png, f);
  if (palette) {
    png_set_compression_level(png, 1);
    png_set_compression_strategy(png, Z_RLE);
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_UP);
    png_set_IHDR(png, info, w, h, 8, PNG_COLOR_TYPE_PALETTE, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_PLTE(png, info, palette, colours);
  } else {
    png_set_compression_level(png, 6);
    png_set_IHDR(png, info, w, h, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  }
  png_write_info(png, info);
  return true;
}

bool row(png_structp png, const std::uint8_t* pixels) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_write_row(png, const_cast<png_bytep>(pixels));
  return true;
}

bool end(png_structp png, png_infop info) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_write_end(png, info);
  return true;
}

}  // namespace

struct PngWriter::Impl {
  AtomicFile out;
  PngState state;
  png_structp png = nullptr;
  png_infop info = nullptr;
  std::size_t height = 0;
  std::size_t rows = 0;
  bool completed = false;

  explicit Impl(const std::string& path) : out(path) {}
  ~Impl() { png_destroy_write_struct(&png, &info); }
  [[noreturn]] void fail(const char* what) {
    const std::string msg = "cannot write PNG " + out.path() + ": " + what +
                            (state.message[0] ? std::string(": ") + state.message : "");
    out.discard();
    throw Error(msg);
  }
};

PngWriter::PngWriter(const std::string& path, std::size_t width, std::size_t height)
    : PngWriter(path, width, height, {}) {}

PngWriter::PngWriter(const std::string& path, std::size_t width, std::size_t height,
                     const std::vector<Rgb>& palette)
    : impl_(std::make_unique<Impl>(path)) {
  // PNG limits each dimension to 2^31 - 1; libpng's default user limit is 10^6.
  if (width == 0 || height == 0 || width > 1000000 || height > 1000000)
    impl_->fail(("image size " + std::to_string(width) + " x " + std::to_string(height) +
                 " outside 1..1000000")
                    .c_str());
  if (palette.size() > 256)
    impl_->fail(("palette of " + std::to_string(palette.size()) + " colours; at most 256").c_str());
  png_color plte[256];
  for (std::size_t i = 0; i < palette.size(); ++i)
    plte[i] = {palette[i].r, palette[i].g, palette[i].b};
  impl_->height = height;
  impl_->png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &impl_->state, on_error, on_warning);
  if (!impl_->png) impl_->fail("png_create_write_struct failed");
  impl_->info = png_create_info_struct(impl_->png);
  if (!impl_->info) impl_->fail("png_create_info_struct failed");
  if (!start(impl_->png, impl_->info, impl_->out.file(), static_cast<png_uint_32>(width),
             static_cast<png_uint_32>(height), palette.empty() ? nullptr : plte,
             static_cast<int>(palette.size())))
    impl_->fail("header");
}

PngWriter::~PngWriter() = default;

void PngWriter::write_row(const std::uint8_t* pixels) {
  if (impl_->rows >= impl_->height) impl_->fail("more rows than the image height");
  if (!row(impl_->png, pixels)) impl_->fail("row");
  // libpng buffers in zlib, but a full disk shows up on the FILE as soon as it flushes.
  if (std::ferror(impl_->out.file())) impl_->fail(std::strerror(errno));
  ++impl_->rows;
}

void PngWriter::complete() {
  if (impl_->completed) return;
  if (impl_->rows != impl_->height)
    impl_->fail(("only " + std::to_string(impl_->rows) + " of " + std::to_string(impl_->height) +
                 " rows written")
                    .c_str());
  if (!end(impl_->png, impl_->info)) impl_->fail("end");
  png_destroy_write_struct(&impl_->png, &impl_->info);
  impl_->out.sync();
  impl_->completed = true;
}

void PngWriter::finish() {
  complete();
  impl_->out.commit();
}

}  // namespace potmap::detail
