#pragma once
// One error type for bad input: says what is wrong and where (file, line, column/field).
#include <stdexcept>
#include <string>

namespace hs {

struct SourceLocation {
  std::string file;   // empty when not from a file
  long line = 0;      // 1-based, 0 = unknown
  std::string field;  // column name or field, empty = unknown
};

class InputError : public std::runtime_error {
 public:
  InputError(SourceLocation where, const std::string& what);
  const SourceLocation& where() const noexcept { return where_; }

 private:
  SourceLocation where_;
};

// "file:line: field: message" (parts omitted when unknown).
std::string format_location(const SourceLocation& where);

}  // namespace hs
