// Private to src/io: names fixed by the results-file contract (docs/guide/results.md).
#pragma once

#include <array>
#include <cstdio>
#include <string>

namespace peristat::io {

/// "%06d" of a step number: the name of its group under /steps.
inline std::string step_group_name(int index) {
  std::array<char, 16> buf{};
  std::snprintf(buf.data(), buf.size(), "%06d", index);
  return buf.data();
}

}  // namespace peristat::io
