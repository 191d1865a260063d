// Private to src/io: the two tools that keep result files valid when a run is stopped.
#pragma once

#include <string>
#include <string_view>

#include <signal.h>

namespace peristat::io {

/// Writes `content` to PATH.tmp and renames it over PATH, so PATH always holds either
/// the old or the new text, never a partial one. Throws std::runtime_error naming PATH.
void write_file_atomically(const std::string& path, std::string_view content);

/// Holds back SIGINT, SIGTERM and SIGHUP for the calling thread while alive; signals
/// that arrive meanwhile are delivered when it is destroyed.
class SignalBlocker {
 public:
  SignalBlocker();
  ~SignalBlocker();
  SignalBlocker(const SignalBlocker&) = delete;
  SignalBlocker& operator=(const SignalBlocker&) = delete;

 private:
  sigset_t m_previous;
  bool m_active = false;
};

}  // namespace peristat::io
