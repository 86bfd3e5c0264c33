#include "frichb/core/support/interrupt.hpp"

#include <atomic>
#include <csignal>
#include <string>

namespace frichb::core {

namespace {
std::atomic<int> g_signal{0};
static_assert(std::atomic<int>::is_always_lock_free);

extern "C" void record_signal(int signal) {
  int none = 0;
  g_signal.compare_exchange_strong(none, signal);
}
}  // namespace

Interrupted::Interrupted(int signal)
    : std::runtime_error("interrupted by signal " + std::to_string(signal) + "; no output written"),
      signal_(signal) {}

void install_interrupt_handlers() {
  struct sigaction action {};
  action.sa_handler = record_signal;
  sigemptyset(&action.sa_mask);
  // A second signal of the same kind ends the process at once (the default action).
  action.sa_flags = SA_RESETHAND;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

int interrupt_signal() {
  return g_signal.load();
}

void request_interrupt(int signal) {
  record_signal(signal);
}

void clear_interrupt() {
  g_signal.store(0);
}

int interrupted_exit_code() {
  const int s = interrupt_signal();
  return s ? 128 + s : 0;
}

}  // namespace frichb::core
