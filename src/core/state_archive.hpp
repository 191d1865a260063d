// The state a run needs to continue after a stop (peristat run --resume): named arrays and
// texts that each part of the model fills with what it remembers between load steps and reads
// back. Plain data, so that the physics folders need no I/O; src/io/checkpoint.hpp stores it.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "core/types.hpp"

namespace peristat {

struct StateArchive {
  /// Every array as doubles: integers (indices, counts) are exact below 2^53.
  std::map<std::string, std::vector<double>> arrays;
  std::map<std::string, std::string> texts;

  void put(const std::string& key, std::vector<double> values) { arrays[key] = std::move(values); }
  void put(const std::string& key, double value) { arrays[key] = {value}; }
  /// The array under `key` with `expected` entries (any length when expected < 0); throws
  /// InputError naming the key when it is missing or has another length (a checkpoint of
  /// another model).
  const std::vector<double>& get(const std::string& key, std::int64_t expected = -1) const {
    const auto it = arrays.find(key);
    if (it == arrays.end()) throw InputError("the checkpoint has no '" + key + "'");
    if (expected >= 0 && static_cast<std::int64_t>(it->second.size()) != expected)
      throw InputError("the checkpoint's '" + key + "' has " + std::to_string(it->second.size()) +
                       " entries, the model " + std::to_string(expected));
    return it->second;
  }
  double scalar(const std::string& key) const { return get(key, 1)[0]; }
  /// An index stored as a double, checked to lie in [lo, hi).
  static Index index(double value, Index lo, Index hi, const std::string& key) {
    if (!(value >= lo && value < hi) || value != static_cast<double>(static_cast<Index>(value)))
      throw InputError("the checkpoint's '" + key + "' holds an index out of range");
    return static_cast<Index>(value);
  }
};

}  // namespace peristat
