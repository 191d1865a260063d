// Schema helpers for reading a yaml-cpp tree with errors that name file, line and key.
// Private to src/scene: nothing outside this folder sees yaml-cpp.
#pragma once

#include <initializer_list>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "core/error.hpp"
#include "core/types.hpp"

namespace peristat::schema {

/// What every error needs: the file name and which dotted paths came from --set.
struct Source {
  std::string file;
  std::set<std::string> overridden;  ///< paths written (or created) by --set overrides

  /// True if `key` is an overridden path or lies below one.
  bool is_overridden(const std::string& key) const;
};

/// "a" + "b" -> "a.b"; "" + "b" -> "b".
std::string join(const std::string& parent, std::string_view name);

/// One node of the tree with its dotted key and the 1-based line that names it (the
/// line of its key for a map entry, of the element for a list item).
class Field {
 public:
  Field(const Source& source, YAML::Node node, std::string key, int line)
      : m_source(&source), m_node(std::move(node)), m_key(std::move(key)), m_line(line) {}

  const YAML::Node& node() const { return m_node; }
  const std::string& key() const { return m_key; }
  int line() const { return m_line; }
  const Source& source() const { return *m_source; }

  /// file:line: key, or --set: key for values that came from an override.
  SourceLocation where() const;
  [[noreturn]] void fail(const std::string& message) const;
  /// The node as written, for messages: "0.7", "a map", "a list", "nothing (null)".
  std::string found() const;

 private:
  const Source* m_source;
  YAML::Node m_node;
  std::string m_key;
  int m_line;
};

/// A map entry checked against its schema: unknown and duplicate keys are rejected.
class Map {
 public:
  const Field& self() const { return m_self; }
  const std::vector<Field>& entries() const { return m_entries; }
  std::optional<Field> find(std::string_view name) const;
  /// The entry, or an error at this map's line: missing required key (`what`).
  Field require(std::string_view name, std::string_view what) const;

 private:
  friend Map checked_map(const Field&, std::initializer_list<std::string_view>);
  friend Map named_map(const Field&, std::string_view);
  explicit Map(Field self) : m_self(std::move(self)) {}
  Field m_self;
  std::vector<Field> m_entries;
};

/// A map whose keys must be among `allowed` (the message lists them).
Map checked_map(const Field& field, std::initializer_list<std::string_view> allowed);
/// A map of user-chosen names (materials, bodies); names are [A-Za-z0-9_-]+ so that
/// --set can address them. `what` names the entries for messages ("material").
Map named_map(const Field& field, std::string_view what);

std::vector<Field> list(const Field& field);
double number(const Field& field);  ///< finite, unquoted
long long integer(const Field& field);
bool boolean(const Field& field);
std::string text(const Field& field);  ///< any scalar, as written
std::string choice(const Field& field, std::span<const std::string_view> options);
inline std::string choice(const Field& field, std::initializer_list<std::string_view> options) {
  return choice(field, std::span(options.begin(), options.size()));
}
Vec2 point(const Field& field);  ///< [x, y]

/// Range checks; the message reads "value 0.7 is out of range: expected <what>".
double positive(const Field& field);                             ///< > 0
double at_least(const Field& field, double lo);                  ///< >= lo
int int_at_least(const Field& field, int lo);                    ///< integer >= lo
double in_open_range(const Field& field, double lo, double hi);  ///< lo < x < hi
[[noreturn]] void out_of_range(const Field& field, const std::string& expected);

/// Last component of a dotted key ("materials.plate.nu" -> "nu").
std::string leaf(const std::string& key);

}  // namespace peristat::schema
