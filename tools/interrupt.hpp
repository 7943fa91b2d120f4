#pragma once
// Ctrl-C (SIGINT) and SIGTERM during a long job: the first asks the job to stop at its next
// keyframe, scan or batch of blocks, where it throws Interrupted; the stack unwinds, so every
// file being written is removed rather than left half-written (temporary files renamed into
// place only when whole), and a checkpoint already written stays for --resume. A second
// signal ends the process at once. The flag is the process's: a signal reaches the process,
// not one job.
#include "potmap/error.hpp"

namespace potmap::cli {

/// Thrown at the first check after a SIGINT or SIGTERM; main() exits with 130.
class Interrupted : public Error {
 public:
  Interrupted() : Error("interrupted") {}
};

/// Installs the handlers (once, from main()).
void catch_interrupts();

/// Throws Interrupted when a signal came since catch_interrupts().
void stop_if_interrupted();

}  // namespace potmap::cli
