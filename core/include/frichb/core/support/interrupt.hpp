// Interruption by SIGINT or SIGTERM: the signal only sets a flag; long computations poll it
// (the continuation at every step, Newton solves at every iteration, studies between runs, child
// programs while they run), stop, discard their staged outputs and return exit code 128 + the
// signal's number. Thread-safe (a lock-free atomic). The flag is process-wide: a recorded stop
// stops every computation of the process. Only the frichb program installs the handlers; a
// program that links the core keeps its own and calls request_interrupt to stop the core.
#pragma once

#include <stdexcept>

namespace frichb::core {

// Thrown where a computation or a writer stops for a recorded signal (StagedOutput::commit
// refuses to commit after one); report_failure maps it to 128 + the signal.
class Interrupted : public std::runtime_error {
 public:
  explicit Interrupted(int signal);
  int signal() const { return signal_; }

 private:
  int signal_;
};

// Installs handlers for SIGINT and SIGTERM that record the signal (the first one wins; a
// second one then ends the process). For the verbs that poll it.
void install_interrupt_handlers();
// The signal that asked the process to stop, or 0.
int interrupt_signal();
inline bool interrupted() {
  return interrupt_signal() != 0;
}
// Records `signal` as if it had arrived (tests; a caller that wants to stop a run).
void request_interrupt(int signal);
// Forgets an earlier interruption (tests).
void clear_interrupt();
// The exit code of a run stopped by the recorded signal: 128 + its number (130 for SIGINT,
// 143 for SIGTERM).
int interrupted_exit_code();

}  // namespace frichb::core
