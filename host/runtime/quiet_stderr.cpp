#include "runtime/quiet_stderr.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <regex>
#include <sstream>

namespace potmap::detail {

QuietStderr::QuietStderr() {
  char name[] = "/tmp/potmap-stderr-XXXXXX";
  file_ = ::mkstemp(name);
  if (file_ < 0) return;
  ::unlink(name);
  std::fflush(stderr);
  saved_ = ::dup(2);
  if (saved_ < 0 || ::dup2(file_, 2) < 0) {
    if (saved_ >= 0) ::close(saved_);
    ::close(file_);
    saved_ = file_ = -1;
  }
}

QuietStderr::~QuietStderr() {
  release();
}

std::string QuietStderr::release() {
  if (saved_ < 0) return {};
  std::fflush(stderr);
  ::dup2(saved_, 2);
  ::close(saved_);
  saved_ = -1;
  std::string out;
  char buf[4096];
  ::lseek(file_, 0, SEEK_SET);
  for (ssize_t n; (n = ::read(file_, buf, sizeof buf)) > 0;) out.append(buf, std::size_t(n));
  ::close(file_);
  file_ = -1;
  return out;
}

std::string not_from_compiler(const std::string& captured, const std::string& log) {
  static const std::regex summary(
      R"(^\s*\d+ (warning|error)s? (and \d+ (warning|error)s? )?generated\.\s*$)");
  std::istringstream in(captured);
  std::string line, rest;
  while (std::getline(in, line)) {
    if (std::regex_match(line, summary)) continue;
    if (!line.empty() && log.find(line) != std::string::npos) continue;
    rest += line + "\n";
  }
  return rest;
}

}  // namespace potmap::detail
