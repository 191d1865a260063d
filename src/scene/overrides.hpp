// --set overrides: applied to the YAML tree before validation.
#pragma once

#include <yaml-cpp/yaml.h>

#include "scene/scene.hpp"
#include "scene/yaml_schema.hpp"

namespace peristat {

/// Writes `value` (parsed as YAML) at the dotted path `key` of `root`: maps are entered by
/// name (missing ones are created), lists by index (existing elements only). Records the
/// path (and every map it created) in source.overridden so errors below it say "--set".
void apply_override(YAML::Node& root, const Override& override_, schema::Source& source);

}  // namespace peristat
