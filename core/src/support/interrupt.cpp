#include "frichb/core/support/interrupt.hpp"

#include <string>

namespace frichb::core {

namespace {
static_assert(std::atomic<int>::is_always_lock_free);
static_assert(std::atomic<std::atomic<int>*>::is_always_lock_free);

// The state the handlers stop, and the source that owns it (kept for the rest of the process,
// and reachable from here: it is not a leak).
std::atomic<std::atomic<int>*> g_handled{nullptr};
const StopSource* g_handled_source = nullptr;

void record(std::atomic<int>& state, int signal) noexcept {
  int none = 0;
  state.compare_exchange_strong(none, signal);
}

extern "C" void record_signal(int signal) {
  if (std::atomic<int>* state = g_handled.load()) record(*state, signal);
}
}  // namespace

Interrupted::Interrupted(int signal)
    : std::runtime_error("interrupted by signal " + std::to_string(signal) + "; no output written"),
      signal_(signal) {}

StopSource::StopSource() : state_(std::make_shared<std::atomic<int>>(0)) {}

void StopSource::request_stop(int signal) const noexcept {
  record(*state_, signal);
}

int StopToken::exit_code() const noexcept {
  const int s = signal();
  return s ? 128 + s : 0;
}

std::string StopToken::reason() const {
  return "interrupted by signal " + std::to_string(signal());
}

void StopToken::throw_if_stopped() const {
  if (stop_requested()) throw Interrupted(signal());
}

void install_interrupt_handlers(const StopSource& source) {
  // The state is kept for the rest of the process: a handler may run at any time after this.
  g_handled_source = new StopSource(source);  // NOLINT(cppcoreguidelines-owning-memory)
  g_handled.store(g_handled_source->state_.get());
  struct sigaction action {};
  action.sa_handler = record_signal;
  sigemptyset(&action.sa_mask);
  // A second signal of the same kind ends the process at once (the default action).
  action.sa_flags = SA_RESETHAND;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

}  // namespace frichb::core
