#include "scene/yaml_schema.hpp"

#include <algorithm>
#include <cctype>
#include <climits>
#include <cmath>
#include <sstream>

namespace peristat::schema {

namespace {

int line_of(const YAML::Node& node, int fallback) {
  const int line = node.Mark().line;
  return line >= 0 ? line + 1 : fallback;
}

bool is_quoted(const YAML::Node& node) {
  return node.Tag() == "!";
}

std::string list_names(std::span<const std::string_view> names) {
  std::string s;
  for (std::string_view n : names) s += (s.empty() ? "" : ", ") + std::string(n);
  return s;
}

std::string format_number(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

/// The scalar of `field`, which must be a plain (unquoted) scalar; `expected` for messages.
const std::string& plain_scalar(const Field& field, std::string_view expected) {
  const YAML::Node& n = field.node();
  if (!n.IsScalar() || is_quoted(n))
    field.fail("expected " + std::string(expected) + ", found " + field.found());
  // yaml-cpp's conversions skip trailing C whitespace such as \f, which YAML keeps in a plain
  // scalar and the emitter then quotes: the scene as run would not parse again (tests/fuzz).
  const std::string& s = n.Scalar();
  if (std::any_of(s.begin(), s.end(), [](unsigned char c) { return std::isspace(c) || std::iscntrl(c); }))
    field.fail("expected " + std::string(expected) + ", found \"" + s + "\"");
  return s;
}

/// The key of one map entry as a string; keys must be scalars.
std::string key_name(const Field& map, const YAML::Node& key) {
  if (!key.IsScalar()) {
    Field k(map.source(), key, map.key(), line_of(key, map.line()));
    k.fail("keys must be plain names, found " + k.found() + " as a key");
  }
  return key.Scalar();
}

/// Walks the entries of a map (null counts as empty), rejecting duplicates; `check`
/// sees each entry's name and Field before it is stored.
template <class Check>
std::vector<Field> map_entries(const Field& field, Check check) {
  const YAML::Node& n = field.node();
  if (n.IsNull()) return {};
  if (!n.IsMap()) field.fail("expected a map (key: value entries), found " + field.found());
  std::vector<Field> entries;
  for (auto it = n.begin(); it != n.end(); ++it) {
    const std::string name = key_name(field, it->first);
    Field entry(field.source(), it->second, join(field.key(), name), line_of(it->first, field.line()));
    for (const Field& seen : entries) {
      if (leaf(seen.key()) == name)
        entry.fail("duplicate key \"" + name + "\": already given at line " + std::to_string(seen.line()));
    }
    check(name, entry);
    entries.push_back(entry);
  }
  return entries;
}

bool is_name_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
}

}  // namespace

bool Source::is_overridden(const std::string& key) const {
  for (const std::string& p : overridden) {
    if (key == p || (key.size() > p.size() && key.starts_with(p) && key[p.size()] == '.')) return true;
  }
  return false;
}

std::string join(const std::string& parent, std::string_view name) {
  return parent.empty() ? std::string(name) : parent + "." + std::string(name);
}

std::string leaf(const std::string& key) {
  const auto dot = key.rfind('.');
  return dot == std::string::npos ? key : key.substr(dot + 1);
}

SourceLocation Field::where() const {
  if (m_source->is_overridden(m_key)) return {"--set", 0, m_key};
  return {m_source->file, m_line, m_key};
}

void Field::fail(const std::string& message) const {
  throw InputError(where(), message);
}

std::string Field::found() const {
  if (!m_node.IsDefined() || m_node.IsNull()) return "nothing (null)";
  if (m_node.IsMap()) return "a map";
  if (m_node.IsSequence()) return "a list";
  return (is_quoted(m_node) ? "the quoted string \"" : "\"") + m_node.Scalar() + "\"";
}

std::optional<Field> Map::find(std::string_view name) const {
  for (const Field& e : m_entries)
    if (leaf(e.key()) == name) return e;
  return std::nullopt;
}

Field Map::require(std::string_view name, std::string_view what) const {
  if (auto f = find(name)) return *f;
  Field missing(m_self.source(), YAML::Node(), join(m_self.key(), name), m_self.line());
  missing.fail("missing required key \"" + std::string(name) + "\": expected " + std::string(what));
}

Map checked_map(const Field& field, std::initializer_list<std::string_view> allowed) {
  Map map(field);
  map.m_entries = map_entries(field, [&](const std::string& name, const Field& entry) {
    for (std::string_view a : allowed)
      if (a == name) return;
    entry.fail("unknown key \"" + name + "\": expected one of " +
               list_names(std::span(allowed.begin(), allowed.size())));
  });
  return map;
}

Map named_map(const Field& field, std::string_view what) {
  Map map(field);
  map.m_entries = map_entries(field, [&](const std::string& name, const Field& entry) {
    for (char c : name) {
      if (!is_name_char(c))
        entry.fail("invalid " + std::string(what) + " name \"" + name +
                   "\": expected letters, digits, '_' and '-' only");
    }
  });
  return map;
}

std::vector<Field> list(const Field& field) {
  const YAML::Node& n = field.node();
  if (n.IsNull()) return {};
  if (!n.IsSequence()) field.fail("expected a list, found " + field.found());
  std::vector<Field> items;
  for (std::size_t i = 0; i < n.size(); ++i)
    items.emplace_back(field.source(), n[i], join(field.key(), std::to_string(i)),
                       line_of(n[i], field.line()));
  return items;
}

double number(const Field& field) {
  const std::string& s = plain_scalar(field, "a number");
  double x = 0.0;
  if (!YAML::convert<double>::decode(field.node(), x)) field.fail("expected a number, found \"" + s + "\"");
  if (!std::isfinite(x)) field.fail("expected a finite number, found \"" + s + "\"");
  return x;
}

long long integer(const Field& field) {
  const std::string& s = plain_scalar(field, "an integer");
  long long x = 0;
  if (!YAML::convert<long long>::decode(field.node(), x))
    field.fail("expected an integer, found \"" + s + "\"");
  return x;
}

bool boolean(const Field& field) {
  const std::string& s = plain_scalar(field, "true or false");
  bool x = false;
  if (!YAML::convert<bool>::decode(field.node(), x))
    field.fail("expected true or false, found \"" + s + "\"");
  return x;
}

std::string text(const Field& field) {
  if (!field.node().IsScalar()) field.fail("expected a string, found " + field.found());
  return field.node().Scalar();
}

std::string choice(const Field& field, std::span<const std::string_view> options) {
  const std::string s = text(field);
  for (std::string_view o : options)
    if (o == s) return s;
  field.fail("value \"" + s + "\" is not allowed: expected one of " + list_names(options));
}

Vec2 point(const Field& field) {
  const YAML::Node& n = field.node();
  if (!n.IsSequence() || n.size() != 2)
    field.fail("expected a point [x, y] (a list of 2 numbers), found " +
               (n.IsSequence() ? "a list of " + std::to_string(n.size()) : field.found()));
  const std::vector<Field> xy = list(field);
  return {number(xy[0]), number(xy[1])};
}

void out_of_range(const Field& field, const std::string& expected) {
  field.fail("value " + field.node().Scalar() + " is out of range: expected " + expected);
}

double positive(const Field& field) {
  const double x = number(field);
  if (!(x > 0.0)) out_of_range(field, leaf(field.key()) + " > 0");
  return x;
}

double at_least(const Field& field, double lo) {
  const double x = number(field);
  if (!(x >= lo)) out_of_range(field, leaf(field.key()) + " >= " + format_number(lo));
  return x;
}

int int_at_least(const Field& field, int lo) {
  const long long x = integer(field);
  if (x < lo) out_of_range(field, leaf(field.key()) + " >= " + std::to_string(lo));
  if (x > INT_MAX) out_of_range(field, leaf(field.key()) + " <= " + std::to_string(INT_MAX));
  return static_cast<int>(x);
}

double in_open_range(const Field& field, double lo, double hi) {
  const double x = number(field);
  if (!(x > lo && x < hi))
    out_of_range(field, format_number(lo) + " < " + leaf(field.key()) + " < " + format_number(hi));
  return x;
}

}  // namespace peristat::schema
