#include "progress.hpp"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <unistd.h>

#include "potmap/error.hpp"

namespace potmap::cli {

std::function<void(double)> terminal_progress(const std::string& label) {
  if (!::isatty(::fileno(stderr))) return {};
  const auto start = std::chrono::steady_clock::now();
  return [start, label](double f) {
    const double el =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double eta = f > 0 ? el * (1 - f) / f : 0;
    std::fprintf(stderr, "\rpotmap: %s %5.1f%%  elapsed %.0f s  ETA %.0f s   ", label.c_str(),
                 100 * f, el, eta);
    if (f >= 1) std::fprintf(stderr, "\n");
    std::fflush(stderr);
  };
}

void write_text_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp-" + std::to_string(::getpid());
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f || !(f << text) || !f.flush()) {
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
      throw Error("cannot write " + path);
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw Error("cannot write " + path + ": " + ec.message());
  }
}

}  // namespace potmap::cli
