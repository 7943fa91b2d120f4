#pragma once
// PoCL's compiler writes clang's summary line ("91 warnings generated.") straight to the
// process's stderr (file descriptor 2) when a kernel built from source has warnings, whatever
// the program's build log holds: a user's terminal is no place for potmap's kernel warnings.
// While one of these lives, descriptor 2 goes to a temporary file; release() restores it and
// returns what was written meanwhile.
#include <string>

namespace potmap::detail {

class QuietStderr {
 public:
  QuietStderr();   ///< does nothing (release() returns "") when no temporary file can be made
  ~QuietStderr();  ///< restores descriptor 2 if release() was not called
  QuietStderr(const QuietStderr&) = delete;
  QuietStderr& operator=(const QuietStderr&) = delete;
  std::string release();

 private:
  int saved_ = -1;
  int file_ = -1;
};

/// What of `captured` did not come from the compiler: the lines that are neither clang's
/// "N warning(s)/error(s) generated." summary nor part of the program's build `log`. Another
/// thread's writes to stderr during the build land here and are written back.
std::string not_from_compiler(const std::string& captured, const std::string& log);

}  // namespace potmap::detail
