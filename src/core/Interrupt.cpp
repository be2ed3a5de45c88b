#include "core/Interrupt.hpp"

#include <csignal>

namespace cassini {

namespace {
volatile std::sig_atomic_t received = 0;
extern "C" void record_signal(int sig) { received = sig; }
}  // namespace

void install_interrupt_handlers() {
  struct sigaction sa {};
  sa.sa_handler = record_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;  // a write or an MPI wait in progress carries on; the step loop stops
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGINT, &sa, nullptr);
}

int interrupt_signal() { return received; }

const char* signal_name(int sig) {
  switch (sig) {
    case SIGTERM: return "SIGTERM";
    case SIGINT: return "SIGINT";
    default: return "a signal";
  }
}

}  // namespace cassini
