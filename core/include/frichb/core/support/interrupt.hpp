// Stopping a call of the core before it ends: each call takes a StopToken in its options (the
// continuation polls it at every step, Newton solves at every iteration, studies between runs,
// time integration every period, writers before they commit and while a child program runs);
// a stopped call ends with what it has (a trace is cancelled), discards its staged outputs and
// reports the exit code 128 + the recorded signal. Stops are per call: a stop requested on one
// StopSource leaves every call holding tokens of other sources running. The frichb program
// installs the SIGINT and SIGTERM handlers that stop its one source; a library never installs
// handlers of its own over its host's (a host stops a call through the source of its token).
#pragma once

#include <atomic>
#include <csignal>
#include <memory>
#include <stdexcept>
#include <string>

namespace frichb::core {

// Thrown where a computation or a writer stops for a stop request (StagedOutput::commit
// refuses to commit after one); report_failure maps it to 128 + the signal.
class Interrupted : public std::runtime_error {
 public:
  explicit Interrupted(int signal);
  int signal() const { return signal_; }

 private:
  int signal_;
};

// What a computation polls to know whether its call was asked to stop: the options of a call
// hold one. A default-constructed token is never stopped; a StopSource gives tokens that see its
// requests. Cheap to copy (copies share the source's state); thread-safe.
class StopToken {
 public:
  StopToken() noexcept = default;

  // The signal recorded by the source, 0 while no stop was requested.
  int signal() const noexcept { return state_ ? state_->load(std::memory_order_relaxed) : 0; }
  bool stop_requested() const noexcept { return signal() != 0; }
  // The exit code of a call stopped through this token: 128 + the signal (130 for SIGINT, 143
  // for SIGTERM), 0 while not stopped.
  int exit_code() const noexcept;
  // "interrupted by signal N": the start of the messages of a stopped call.
  std::string reason() const;
  // Throws Interrupted when a stop was requested.
  void throw_if_stopped() const;

 private:
  friend class StopSource;
  explicit StopToken(std::shared_ptr<const std::atomic<int>> state) noexcept
      : state_(std::move(state)) {}
  std::shared_ptr<const std::atomic<int>> state_;
};

// The caller's side: requests a stop that every token it gave sees at the computation's next
// poll. Copies share one state. request_stop is lock-free and async-signal-safe (a signal
// handler may call it) and may be called from any thread.
class StopSource {
 public:
  StopSource();

  StopToken token() const noexcept { return StopToken(state_); }
  // Records `signal` as the reason to stop (the first request wins; later ones are ignored).
  // A caller without a signal of its own passes the default, SIGINT (exit code 130).
  void request_stop(int signal = SIGINT) const noexcept;
  bool stop_requested() const noexcept { return state_->load(std::memory_order_relaxed) != 0; }

 private:
  friend void install_interrupt_handlers(const StopSource& source);
  std::shared_ptr<std::atomic<int>> state_;
};

// Installs handlers for SIGINT and SIGTERM that request a stop of `source` (its state is kept
// for the rest of the process; the first signal wins; a second one of the same kind ends the
// process by the default action). For a program's main, before it starts a call with a token of
// that source.
void install_interrupt_handlers(const StopSource& source);

}  // namespace frichb::core
