#pragma once
// Ctrl-C (SIGINT) and SIGTERM during a job that checks for them (a drive's mapping): the first
// asks the job to stop at its next keyframe or batch of blocks, where it throws Interrupted;
// the stack unwinds, so every file being written is removed rather than left half-written
// (temporary files renamed into place only when whole), and a checkpoint already written stays
// for --resume. A second signal ends the process at once. Only such a job catches them (an
// InterruptScope for its length): any other command ends at the first, as it always did. The
// flag is the process's: a signal reaches the process, not one job.
#include "potmap/error.hpp"

namespace potmap::cli {

/// Thrown at the first check after a SIGINT or SIGTERM; main() exits with 130.
class Interrupted : public Error {
 public:
  Interrupted() : Error("interrupted") {}
};

/// The handlers installed for the scope's length, the previous ones restored after it.
class InterruptScope {
 public:
  InterruptScope();
  ~InterruptScope();
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;

 private:
  void (*previous_[2])(int);
};

/// Throws Interrupted when a signal came while an InterruptScope was open.
void stop_if_interrupted();

}  // namespace potmap::cli
