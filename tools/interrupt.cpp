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

InterruptScope::InterruptScope() {
  g_signal = 0;
  previous_[0] = std::signal(SIGINT, on_signal);
  previous_[1] = std::signal(SIGTERM, on_signal);
}

InterruptScope::~InterruptScope() {
  std::signal(SIGINT, previous_[0] == SIG_ERR ? SIG_DFL : previous_[0]);
  std::signal(SIGTERM, previous_[1] == SIG_ERR ? SIG_DFL : previous_[1]);
}

void stop_if_interrupted() {
  if (g_signal != 0) throw Interrupted();
}

}  // namespace potmap::cli
