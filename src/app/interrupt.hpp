// Ctrl-C and kill during a run. The first SIGINT/SIGTERM/SIGHUP requests a stop, which the
// run honours at its next poll (src/core/stop.hpp: a Newton or Krylov iteration, an ADR
// step); the results keep every converged step and summary.json says "interrupted". A
// second one exits at once, unless a step is being written, in which case the exit waits
// for the write to finish. Either way the files stay valid.
#pragma once

#include "core/stop.hpp"  // Interrupted, thrown by the polls once a signal has arrived

namespace peristat {

void install_interrupt_handlers();

/// Marks the span of a results write: a second signal inside it is deferred to its end.
class WriteGuard {
 public:
  WriteGuard();
  ~WriteGuard();
  WriteGuard(const WriteGuard&) = delete;
  WriteGuard& operator=(const WriteGuard&) = delete;
};

}  // namespace peristat
