// One error type for bad input: the message names the file and the problem, so the
// command line can print it as one line and exit non-zero.
#pragma once

#include <fmt/format.h>

#include <cstdio>
#include <stdexcept>
#include <string>
#include <string_view>

namespace oblong {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Error("scene.json: unknown key 'foo'") style: `where` is a file (optionally with a
// JSON path), `what` the problem.
template <typename... Args>
[[noreturn]] void fail(const std::string& where, fmt::format_string<Args...> f, Args&&... args) {
  throw Error(where + ": " + fmt::format(f, std::forward<Args>(args)...));
}

// A piece of an input file shown in a message: at most `max` bytes (then "..."), control
// characters and bytes outside printable ASCII escaped (\n, \t, \xNN), so that one
// line stays one short line whatever the file holds.
inline std::string excerpt(std::string_view s, size_t max = 60) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (out.size() >= max) return out + "...";
    const unsigned char c = (unsigned char)s[i];
    if (c == '\n') out += "\\n";
    else if (c == '\t') out += "\\t";
    else if (c == '\r') out += "\\r";
    else if (c == '\\') out += "\\\\";
    else if (c < 0x20 || c >= 0x7f) out += fmt::format("\\x{:02x}", c);
    else out += char(c);
  }
  return out;
}

// Prints a message on stderr and never throws: fmt::print throws when the write fails
// (stderr closed or full), and a message must never end the process or lose a result.
template <typename... Args>
void eprint(fmt::format_string<Args...> f, Args&&... args) noexcept {
  try {
    const std::string s = fmt::format(f, std::forward<Args>(args)...);
    std::fwrite(s.data(), 1, s.size(), stderr);
    std::fflush(stderr);
    std::clearerr(stderr);
  } catch (...) {
  }
}

}  // namespace oblong
