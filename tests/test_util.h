// Shared helpers for the tests: scratch folders (tests/scratch.h), running the oblong
// binary, and small image writers.
#pragma once

#include "tests/scratch.h"

#include <OpenImageIO/imageio.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace oblong::test {

// A shipped scene (a path under scenes/) as the tests load it: the build's copy
// (tests/test_data.cmake) where the scene names Debian's glmark2 data, else scenes/'s own.
inline std::string shippedScene(const std::string& rel) {
  const std::filesystem::path copy = std::filesystem::path(OBLONG_TEST_DATA) / "scenes" / rel;
  return std::filesystem::exists(copy) ? copy.string() : std::string(OBLONG_SOURCE_DIR) + "/scenes/" + rel;
}

inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

// Runs the oblong binary with `args` (a shell command line tail), capturing both streams.
struct CliRun {
  int status;
  std::string out, err;
};
inline CliRun runOblongCli(const std::string& args) {
  const auto dir = scratchDir("cli_run");
  const auto o = dir / "stdout.txt", e = dir / "stderr.txt";
  const std::string cmd = std::string(OBLONG_BINARY) + " " + args + " >" + o.string() + " 2>" + e.string();
  const int raw = std::system(cmd.c_str());
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1, slurp(o), slurp(e)};
}

// Ctrl-C once a command runs: starts `cmd` under /bin/sh, waits up to `seconds` until
// the file `log` (the command's stderr) contains `marker`, sends SIGINT 300 ms later and
// waits for the command. `reached`: the marker appeared; `status`: waitpid's status.
struct Interrupted {
  bool reached;
  int status;
};
inline Interrupted interruptOnce(const std::string& cmd, const std::filesystem::path& log, const std::string& marker,
                                 int seconds) {
  const pid_t pid = ::fork();
  if (pid < 0) return {false, -1};
  if (pid == 0) {
    ::execl("/bin/sh", "sh", "-c", ("exec " + cmd).c_str(), (char*)nullptr);
    ::_exit(127);
  }
  bool reached = false;
  for (int i = 0; i < 10 * seconds && !reached; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    reached = slurp(log).find(marker) != std::string::npos;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  ::kill(pid, SIGINT);
  int raw = 0;
  ::waitpid(pid, &raw, 0);
  return {reached, raw};
}

// Writes a single-channel image from float values in [0,1] (or any, for float files).
inline void writeGray(const std::string& path, int w, int h, const std::vector<float>& v, OIIO::TypeDesc type) {
  auto out = OIIO::ImageOutput::create(path);
  OIIO::ImageSpec spec(w, h, 1, type);
  out->open(path, spec);
  out->write_image(OIIO::TypeDesc::FLOAT, v.data());
  out->close();
}

// Base64 (RFC 4648, with padding): data URIs of glTF buffers.
inline std::string base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    uint32_t v = uint32_t((unsigned char)bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= uint32_t((unsigned char)bytes[i + 1]) << 8;
    if (i + 2 < bytes.size()) v |= uint32_t((unsigned char)bytes[i + 2]);
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? k[(v >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? k[v & 63] : '=';
  }
  return out;
}

// CRC-32 as PNG chunks use it (ISO 3309, reflected, polynomial 0xEDB88320).
inline uint32_t crc32(const std::string& bytes) {
  uint32_t c = 0xFFFFFFFFu;
  for (unsigned char b : bytes) {
    c ^= b;
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
  }
  return c ^ 0xFFFFFFFFu;
}

}  // namespace oblong::test
