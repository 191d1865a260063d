#include "app/interrupt.hpp"

#include <csignal>
#include <initializer_list>
#include <unistd.h>

#include "core/stop.hpp"

namespace peristat {

namespace {
volatile std::sig_atomic_t g_writing = 0;
volatile std::sig_atomic_t g_exit_pending = 0;

extern "C" void on_signal(int sig) {
  if (stop_requested() == 0) {
    request_stop(sig);  // polled by the run (src/core/stop.hpp)
    return;
  }
  if (g_writing) {
    g_exit_pending = sig;
    return;
  }
  _exit(128 + sig);  // async-signal-safe; the files are closed and valid between writes
}
}  // namespace

void install_interrupt_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaction(sig, &sa, nullptr);
}

WriteGuard::WriteGuard() {
  g_writing = 1;
}

WriteGuard::~WriteGuard() {
  g_writing = 0;
  if (g_exit_pending) _exit(128 + g_exit_pending);
}

}  // namespace peristat
