// One error type for bad input: the message names the file and the problem, so the
// command line can print it as one line and exit non-zero.
#pragma once

#include <fmt/format.h>

#include <stdexcept>
#include <string>

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

}  // namespace oblong
