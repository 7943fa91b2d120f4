#include "interrupt.hpp"

#include <csignal>

namespace potmap::cli {

namespace {

// Written by the handler: a lock-free atomic flag is all a handler may touch.
volatile std::sig_atomic_t g_signal = 0;

extern "C" void on_signal(int sig) {
  g_signal = sig;
  std::signal(sig, SIG_DFL);  // the second one ends the process
}

}  // namespace

void catch_interrupts() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

void stop_if_interrupted() {
  if (g_signal != 0) throw Interrupted();
}

}  // namespace potmap::cli
