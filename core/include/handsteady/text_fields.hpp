#pragma once
// Text helpers shared by the CSV readers (tracks, font strokes) and the importers: field
// splitting and number parsing with errors that name file, line and column, and the
// "# key: value" metadata lines of the CSV formats.
#include "handsteady/error.hpp"

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace hs {

// Without leading blanks/tabs and trailing blanks/tabs/CR.
std::string_view trim_field(std::string_view s);
// Comma-separated fields, each trimmed.
std::vector<std::string_view> split_commas(std::string_view line);
// A finite double ('+' allowed) or InputError at `where` ("'x' is not a (finite) number").
double parse_finite_number(std::string_view text, const SourceLocation& where);

// The text of a '#' line without "#" and one space; nullopt for other lines.
std::optional<std::string_view> comment_text(std::string_view trimmed_line);
// Metadata in '#' lines: "key: value". meta_value returns the last value for key;
// set_meta_value replaces every line for key by one at the end.
std::optional<std::string> meta_value(const std::vector<std::string>& lines, std::string_view key);
void set_meta_value(std::vector<std::string>& lines, std::string_view key, std::string_view value);

}  // namespace hs
