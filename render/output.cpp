#include "render/output.h"

#include "core/error.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace oblong {

namespace fs = std::filesystem;

namespace {

// The file a name finally refers to: symbolic links followed (also dangling ones, whose
// target the write creates), relative targets taken against the link's folder.
fs::path resolve(const std::string& path) {
  fs::path p(path);
  std::error_code ec;
  for (int hops = 0; hops < 40 && fs::is_symlink(fs::symlink_status(p, ec)); ++hops) {
    const fs::path t = fs::read_symlink(p, ec);
    if (ec) break;
    p = t.is_absolute() ? t : p.parent_path() / t;
  }
  return p;
}

fs::path folderOf(const fs::path& p) { return p.has_parent_path() ? p.parent_path() : fs::path("."); }

std::string errnoText() { return std::strerror(errno); }

// Every byte of `data` to `fd`, then close; one line naming `path` on failure.
void writeAllAndClose(int fd, const std::string& path, const char* data, size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, data, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) {
      const std::string why = w < 0 ? errnoText() : "no progress";
      ::close(fd);
      fail(path, "write failed ({})", why);
    }
    data += w, n -= size_t(w);
  }
  if (::close(fd) != 0) fail(path, "write failed on close ({})", errnoText());
}

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  if (!f) fail(p.string(), "cannot read back the temporary output");
  return std::string(std::istreambuf_iterator<char>(f), {});
}

// A new empty temporary file name in `folder` with `ext`, created 0666 & ~umask like
// any other output.
fs::path makeTemp(const fs::path& folder, const std::string& stem, const std::string& ext) {
  std::string name = (folder / ("." + stem + ".oblong-XXXXXX")).string() + ext;
  const int fd = ::mkstemps(name.data(), int(ext.size()));
  if (fd < 0) fail(name, "cannot create a temporary output file ({})", errnoText());
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::fchmod(fd, 0666 & ~mask);
  ::close(fd);
  return name;
}

}  // namespace

void checkOutputPath(const std::string& path, const std::string& what) {
  if (path.empty()) fail("(empty name)", "the {} output needs a file name", what);
  const fs::path target = resolve(path);
  std::error_code ec;
  const fs::file_status st = fs::status(target, ec);
  if (fs::is_directory(st)) fail(path, "cannot write {}: is a directory", what);
  if (fs::exists(st) && !fs::is_regular_file(st)) {  // a device or FIFO: written through
    if (::access(target.c_str(), W_OK) != 0) fail(path, "cannot write {} ({})", what, errnoText());
    return;
  }
  const fs::path folder = folderOf(target);
  if (!fs::is_directory(folder, ec)) fail(path, "cannot write {}: folder '{}' does not exist", what, folder.string());
  if (::access(folder.c_str(), W_OK | X_OK) != 0)
    fail(path, "cannot write {}: folder '{}' is not writable ({})", what, folder.string(), errnoText());
  if (fs::exists(st) && ::access(target.c_str(), W_OK) != 0) fail(path, "cannot write {} ({})", what, errnoText());
}

void checkDistinctOutputs(const std::vector<std::pair<std::string, std::string>>& outputs) {
  for (size_t i = 0; i < outputs.size(); ++i)
    for (size_t j = i + 1; j < outputs.size(); ++j) {
      const auto& [fa, a] = outputs[i];
      const auto& [fb, b] = outputs[j];
      if (a.empty() || b.empty()) continue;
      const fs::path ra = fs::weakly_canonical(resolve(a)), rb = fs::weakly_canonical(resolve(b));
      if (ra == rb && ra.string().rfind("/dev/", 0) != 0)
        fail(b, "{} and {} name the same file", fa, fb);
    }
}

void writeOutput(const std::string& path, const std::function<void(const std::string&)>& write) {
  const fs::path target = resolve(path);
  const std::string ext = target.extension().string(), stem = target.filename().string();
  std::error_code ec;
  const fs::file_status st = fs::status(target, ec);
  const bool through = fs::exists(st) && !fs::is_regular_file(st);
  const fs::path tmp = makeTemp(through ? fs::temp_directory_path() : folderOf(target), stem, ext);
  try {
    write(tmp.string());
    if (through) {
      const std::string bytes = slurp(tmp);
      const int fd = ::open(target.c_str(), O_WRONLY | O_CLOEXEC);
      if (fd < 0) fail(path, "cannot open for writing ({})", errnoText());
      writeAllAndClose(fd, path, bytes.data(), bytes.size());
      fs::remove(tmp, ec);
    } else if (::rename(tmp.c_str(), target.c_str()) != 0) {
      fail(path, "cannot move the finished output into place ({})", errnoText());
    }
  } catch (...) {
    fs::remove(tmp, ec);
    throw;
  }
}

void writeTextOutput(const std::string& path, const std::string& text) {
  writeOutput(path, [&](const std::string& tmp) {
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (fd < 0) fail(path, "cannot open for writing ({})", errnoText());
    writeAllAndClose(fd, path, text.data(), text.size());
  });
}

}  // namespace oblong
