// Numbers in messages and XML attributes: the shortest decimal that reads back as the same
// double (JSON output goes through nlohmann::json, which formats its numbers itself).
#pragma once

#include <array>
#include <charconv>
#include <cmath>
#include <string>

namespace peristat {

/// "1", "0.25", "1e-10": std::to_chars' shortest round-trip form. NaN and infinities give
/// "null", as the hand-written JSON writer this replaces did.
inline std::string shortest_decimal(double value) {
  if (!std::isfinite(value)) return "null";
  std::array<char, 32> buf{};
  const auto result = std::to_chars(buf.data(), buf.data() + buf.size(), value);
  return std::string(buf.data(), result.ptr);
}

}  // namespace peristat
