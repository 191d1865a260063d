// A request to stop the run (Ctrl-C, kill), polled where work can run for long: between
// Newton iterations (the run's progress observer), in every Krylov iteration of the
// factor-preconditioned solvers and in every ADR pseudo-time step. The program's signal
// handler (src/app/interrupt.cpp) sets it; a poll throws Interrupted, which the run turns
// into exit 128 + signal with every converged step kept (docs/guide/results.md, "Ctrl-C").
#pragma once

#include <csignal>

namespace peristat {

/// Thrown by a poll once a stop was requested.
struct Interrupted {
  int signal;
};

namespace stop_detail {
inline volatile std::sig_atomic_t g_signal = 0;
}  // namespace stop_detail

/// Async-signal-safe: the first signal's number (a later one does not overwrite it).
inline void request_stop(int signal) {
  if (stop_detail::g_signal == 0) stop_detail::g_signal = signal;
}
/// The signal of the stop request, or 0.
inline int stop_requested() {
  return stop_detail::g_signal;
}
/// Throws Interrupted once a stop was requested; one read of a volatile flag otherwise.
inline void throw_if_stop_requested() {
  if (const int signal = stop_detail::g_signal) throw Interrupted{signal};
}
/// Forgets a request (tests that request one and go on).
inline void clear_stop_request() {
  stop_detail::g_signal = 0;
}

}  // namespace peristat
