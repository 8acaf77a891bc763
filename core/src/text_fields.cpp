#include "handsteady/text_fields.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>

namespace hs {

std::string_view trim_field(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split_commas(std::string_view line) {
  std::vector<std::string_view> out;
  size_t start = 0;
  for (;;) {
    const size_t comma = line.find(',', start);
    out.push_back(trim_field(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start)));
    if (comma == std::string_view::npos) return out;
    start = comma + 1;
  }
}

double parse_finite_number(std::string_view text, const SourceLocation& where) {
  double v = 0.0;
  const char* first = text.data();
  const char* last = text.data() + text.size();
  if (first != last && *first == '+') ++first;
  const auto [ptr, ec] = std::from_chars(first, last, v);
  if (text.empty() || ec != std::errc() || ptr != last)
    throw InputError(where, fmt::format("'{}' is not a number", text));
  if (!std::isfinite(v)) throw InputError(where, fmt::format("'{}' is not a finite number", text));
  return v;
}

std::optional<std::string_view> comment_text(std::string_view trimmed_line) {
  if (trimmed_line.empty() || trimmed_line.front() != '#') return std::nullopt;
  trimmed_line.remove_prefix(1);
  if (!trimmed_line.empty() && trimmed_line.front() == ' ') trimmed_line.remove_prefix(1);
  return trimmed_line;
}

std::optional<std::string> meta_value(const std::vector<std::string>& lines, std::string_view key) {
  std::optional<std::string> value;
  for (const auto& line : lines) {
    const std::string_view l(line);
    if (l.size() > key.size() && l.substr(0, key.size()) == key && l[key.size()] == ':')
      value = std::string(trim_field(l.substr(key.size() + 1)));
  }
  return value;
}

void set_meta_value(std::vector<std::string>& lines, std::string_view key, std::string_view value) {
  const std::string prefix = std::string(key) + ":";
  std::erase_if(lines, [&](const std::string& l) { return l.rfind(prefix, 0) == 0; });
  lines.push_back(prefix + " " + std::string(value));
}

}  // namespace hs
