#include "scene/overrides.hpp"

#include <algorithm>
#include <cctype>

namespace peristat {

namespace {

const char* const example = "expected KEY=VALUE with KEY a dotted path, e.g. solver.linear=umfpack";

[[noreturn]] void fail(const std::string& key, const std::string& message) {
  throw InputError(SourceLocation{"--set", 0, key}, message);
}

std::string name_of(const std::string& path) {
  return path.empty() ? "the scene" : path;
}

std::string trim(const std::string& s) {
  const auto first = std::find_if_not(s.begin(), s.end(), [](unsigned char c) { return std::isspace(c); });
  const auto last = std::find_if_not(s.rbegin(), s.rend(), [](unsigned char c) { return std::isspace(c); });
  return first < last.base() ? std::string(first, last.base()) : std::string();
}

/// "a.b.0" -> {"a", "b", "0"}; empty components are an error.
std::vector<std::string> split_key(const std::string& key) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = key.find('.', start);
    parts.push_back(key.substr(start, dot - start));
    if (parts.back().empty() || parts.back().find_first_of(" \t=") != std::string::npos)
      fail(key, std::string("invalid key \"") + key + "\": " + example);
    if (dot == std::string::npos) return parts;
    start = dot + 1;
  }
}

YAML::Node parse_value(const Override& o) {
  try {
    return YAML::Load(o.value);
  } catch (const YAML::Exception& e) {
    fail(o.key, "cannot read the value \"" + o.value + "\" as YAML: " + e.msg);
  }
}

/// Index of an existing element of the list at `parent`.
std::size_t list_index(const YAML::Node& list, const std::string& part, const std::string& parent,
                       const std::string& path) {
  const bool digits = std::all_of(part.begin(), part.end(), [](unsigned char c) { return std::isdigit(c); });
  const std::string size = std::to_string(list.size());
  if (!digits || part.size() > 9)
    fail(path,
         "\"" + part + "\" is not a list index: " + name_of(parent) + " is a list of " + size + " entries");
  const std::size_t index = std::stoul(part);
  if (index >= list.size())
    fail(path,
         "index " + part + " is out of range: " + name_of(parent) + " is a list of " + size + " entries");
  return index;
}

void require_container(const YAML::Node& node, const std::string& parent, const std::string& path) {
  if (node.IsScalar())
    fail(path, "cannot set a key below " + name_of(parent) + ", which holds the value \"" + node.Scalar() +
                   "\", not a map");
}

}  // namespace

Override parse_override(const std::string& assignment) {
  const std::size_t eq = assignment.find('=');
  if (eq == std::string::npos) fail("", "found \"" + assignment + "\": " + example);
  Override o{trim(assignment.substr(0, eq)), trim(assignment.substr(eq + 1))};
  if (o.key.empty()) fail("", "found \"" + assignment + "\" with an empty key: " + example);
  split_key(o.key);
  return o;
}

void apply_override(YAML::Node& root, const Override& override_, schema::Source& source) {
  const std::vector<std::string> parts = split_key(override_.key);
  const YAML::Node value = parse_value(override_);
  YAML::Node node = root;  // shares root's data; reset() below moves the handle only
  std::string path;
  for (std::size_t i = 0; i < parts.size(); ++i) {
    const std::string parent = path;
    path = schema::join(path, parts[i]);
    require_container(node, parent, path);
    const bool last = i + 1 == parts.size();
    if (node.IsSequence()) {
      const std::size_t index = list_index(node, parts[i], parent, path);
      if (last)
        node[index] = value;
      else
        node.reset(node[index]);
      continue;
    }
    if (last) {
      node[parts[i]] = value;
    } else {
      if (!node[parts[i]].IsDefined() || node[parts[i]].IsNull()) {
        node[parts[i]] = YAML::Node(YAML::NodeType::Map);
        source.overridden.insert(path);
      }
      node.reset(node[parts[i]]);
    }
  }
  source.overridden.insert(override_.key);
}

}  // namespace peristat
