// A tiny streaming JSON writer (enough for summary.json and its "run" object).
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace peristat::json {

/// `"text"` with JSON escapes (quotes, backslash, control characters as \uXXXX).
std::string quote(std::string_view text);
/// Shortest round-trip decimal; NaN and infinities become null (JSON has no such numbers).
std::string number(double value);

/// Builds JSON text; commas and indentation are handled by the writer. Usage:
///   Writer w; w.begin_object(); w.key("a"); w.value(1.0); w.end_object(); w.str();
class Writer {
 public:
  void begin_object();
  void end_object();
  void begin_array();
  void end_array();
  void key(std::string_view name);
  void value(double v);
  void value(long long v);
  void value(int v) { value(static_cast<long long>(v)); }
  void value(std::string_view text);
  void value(const char* text) { value(std::string_view(text)); }
  void value(bool b) { raw(b ? "true" : "false"); }
  /// key(name) then value(v).
  template <class T>
  void field(std::string_view name, const T& v) {
    key(name);
    value(v);
  }
  void null();
  /// A flat array of numbers on one line: [1, 2.5, null].
  void numbers(const std::vector<double>& values);
  /// Inserts already-formatted JSON text (e.g. an object received from elsewhere).
  void raw(std::string_view json_text);
  const std::string& str() const { return m_out; }

 private:
  void before_value();
  void open(char bracket);
  void close(char bracket);
  void newline();

  struct Level {
    bool is_object = false;
    bool empty = true;
  };
  std::string m_out;
  std::vector<Level> m_stack;
  bool m_after_key = false;
};

}  // namespace peristat::json
