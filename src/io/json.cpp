#include "io/json.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>

namespace peristat::json {

std::string quote(std::string_view text) {
  std::string out;
  out.reserve(text.size() + 2);
  out += '"';
  for (const char c : text) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\b':
        out += "\\b";
        break;
      case '\f':
        out += "\\f";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\r':
        out += "\\r";
        break;
      case '\t':
        out += "\\t";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          std::array<char, 8> buf{};
          std::snprintf(buf.data(), buf.size(), "\\u%04x", static_cast<unsigned>(c));
          out += buf.data();
        } else {
          out += c;  // UTF-8 bytes pass through unchanged
        }
    }
  }
  out += '"';
  return out;
}

std::string number(double value) {
  if (!std::isfinite(value)) return "null";
  std::array<char, 32> buf{};
  const auto result = std::to_chars(buf.data(), buf.data() + buf.size(), value);
  return std::string(buf.data(), result.ptr);
}

void Writer::newline() {
  m_out += '\n';
  m_out.append(2 * m_stack.size(), ' ');
}

void Writer::before_value() {
  if (m_after_key) {
    m_after_key = false;
    return;
  }
  if (m_stack.empty()) return;
  Level& level = m_stack.back();
  if (!level.empty) m_out += ',';
  level.empty = false;
  newline();
}

void Writer::open(char bracket) {
  before_value();
  m_out += bracket;
  m_stack.push_back(Level{bracket == '{', true});
}

void Writer::close(char bracket) {
  const bool was_empty = m_stack.back().empty;
  m_stack.pop_back();
  if (!was_empty) newline();
  m_out += bracket;
}

void Writer::begin_object() {
  open('{');
}
void Writer::end_object() {
  close('}');
}
void Writer::begin_array() {
  open('[');
}
void Writer::end_array() {
  close(']');
}

void Writer::key(std::string_view name) {
  before_value();
  m_out += quote(name);
  m_out += ": ";
  m_after_key = true;
}

void Writer::value(double v) {
  before_value();
  m_out += number(v);
}

void Writer::value(long long v) {
  before_value();
  m_out += std::to_string(v);
}

void Writer::value(std::string_view text) {
  before_value();
  m_out += quote(text);
}

void Writer::null() {
  before_value();
  m_out += "null";
}

void Writer::numbers(const std::vector<double>& values) {
  before_value();
  m_out += '[';
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i > 0) m_out += ", ";
    m_out += number(values[i]);
  }
  m_out += ']';
}

void Writer::raw(std::string_view json_text) {
  before_value();
  m_out += json_text;
}

}  // namespace peristat::json
