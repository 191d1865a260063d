#include "io/safe_write.hpp"

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <system_error>

#include <pthread.h>

namespace peristat::io {

void write_file_atomically(const std::string& path, std::string_view content) {
  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) {
      throw std::runtime_error("cannot open '" + temporary + "' for writing: " + std::strerror(errno));
    }
    out.write(content.data(), static_cast<std::streamsize>(content.size()));
    out.flush();
    if (!out) throw std::runtime_error("cannot write '" + temporary + "'");
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) {
    throw std::runtime_error("cannot rename '" + temporary + "' to '" + path + "': " + error.message());
  }
}

SignalBlocker::SignalBlocker() {
  sigset_t held;
  sigemptyset(&held);
  sigaddset(&held, SIGINT);
  sigaddset(&held, SIGTERM);
  sigaddset(&held, SIGHUP);
  // pthread_sigmask is sigprocmask made well-defined for multithreaded (OpenMP) programs.
  m_active = pthread_sigmask(SIG_BLOCK, &held, &m_previous) == 0;
}

SignalBlocker::~SignalBlocker() {
  if (m_active) pthread_sigmask(SIG_SETMASK, &m_previous, nullptr);
}

}  // namespace peristat::io
