// Which peristat this is: the project's version (CMakeLists.txt) and the source's commit
// (`git describe --dirty`, or "unknown" when built outside a git work tree), stamped at
// every build by cmake/version.cmake. `peristat --version` prints them, and every results
// file records them (summary.json "program", the HDF5 file's root attributes).
#pragma once

#include <string>
#include <string_view>

namespace peristat {

std::string_view program_version();
std::string_view program_commit();
/// "peristat 0.1.0 (commit 1a2b3c4d5e6f)".
inline std::string program_description() {
  return "peristat " + std::string(program_version()) + " (commit " + std::string(program_commit()) + ")";
}

}  // namespace peristat
