#include "handsteady/error.hpp"

namespace hs {

std::string format_location(const SourceLocation& w) {
  // A command-line option (no file, the field is the option): "option --horizon-ms".
  if (w.file.empty() && w.line <= 0 && w.field.rfind("--", 0) == 0) return "option " + w.field;
  std::string s = w.file.empty() ? std::string("<input>") : w.file;
  if (w.line > 0) s += ":" + std::to_string(w.line);
  if (!w.field.empty()) s += ": column '" + w.field + "'";
  return s;
}

InputError::InputError(SourceLocation where, const std::string& what)
    : std::runtime_error(format_location(where) + ": " + what), where_(std::move(where)) {}

}  // namespace hs
