// Wall-clock seconds for timings reported to users (steady, monotonic).
#pragma once

#include <chrono>

namespace peristat {

inline double wall_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace peristat
