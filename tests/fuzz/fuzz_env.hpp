#pragma once
// The environment fuzzers' input: lines NAME=value. Clears `variables`, then sets each one
// a line names to that line's value (other names are ignored; a value holding a NUL
// byte, which no environment value can, is skipped).
#include <algorithm>
#include <cstdlib>
#include <string>
#include <string_view>

namespace hs::fuzz {

template <class Names>
void set_env_from_lines(std::string_view text, const Names& variables) {
  for (const char* v : variables) unsetenv(v);
  for (size_t from = 0; from < text.size();) {
    const size_t end = std::min(text.find('\n', from), text.size());
    const std::string_view line = text.substr(from, end - from);
    from = end + 1;
    const size_t eq = line.find('=');
    if (eq == std::string_view::npos) continue;
    const std::string name(line.substr(0, eq)), value(line.substr(eq + 1));
    if (value.find('\0') != std::string::npos) continue;
    for (const char* v : variables)
      if (name == v) setenv(v, value.c_str(), 1);
  }
}

}  // namespace hs::fuzz
