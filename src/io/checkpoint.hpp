// The checkpoint of a run (peristat run --resume, docs/guide/results.md): the StateArchive of
// the last accepted nominal step in DIR/<name>.checkpoint.h5, written to a temporary file and
// renamed over the old one, so that the file holds one whole checkpoint at every instant.
#pragma once

#include <string>

#include "core/state_archive.hpp"

namespace peristat {

/// Writes `archive` to PATH.tmp and renames it over PATH. Throws std::runtime_error naming PATH.
void write_checkpoint(const std::string& path, const StateArchive& archive);

/// Reads a checkpoint; throws InputError naming PATH when it is missing or not a checkpoint.
StateArchive read_checkpoint(const std::string& path);

}  // namespace peristat
