#include "render/output.h"

#include "core/error.h"
#include "core/input_file.h"

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
// target the write creates), relative targets taken against the link's folder. A loop
// of links is an error naming the output.
// /proc's links (/dev/stdout is /proc/self/fd/1) are not followed: their targets
// ("pipe:[123]") are no names, and opening the link itself reaches the open file.
bool inProc(const fs::path& p) { return p.string().rfind("/proc/", 0) == 0; }

fs::path resolve(const std::string& path, bool throws = true) {
  fs::path p(path);
  std::error_code ec;
  for (int hops = 0; !inProc(p) && fs::is_symlink(fs::symlink_status(p, ec)); ++hops) {
    if (hops == 40 && throws) fail(path, "cannot write: a loop of symbolic links");
    const fs::path t = fs::read_symlink(p, ec);
    if ((ec || hops == 40) && !throws) return p;
    if (ec) fail(path, "cannot write: cannot read the symbolic link ({})", ec.message());
    p = t.is_absolute() ? t : p.parent_path() / t;
  }
  return p;
}

// A name to compare outputs by: absolute, links followed, '.' and '..' resolved.
fs::path comparable(const std::string& path, bool throws = true) {
  std::error_code ec;
  const fs::path abs = fs::absolute(resolve(path, throws), ec);
  if (ec) return fs::path(path).lexically_normal();
  const fs::path c = fs::weakly_canonical(abs, ec);
  return ec ? abs.lexically_normal() : c;
}

// Written through rather than replaced: a device, a FIFO, or a file reached through /proc
// (standard output redirected to a file: replacing the name would lose what is written).
bool isDevice(const fs::path& p) {
  std::error_code ec;
  const fs::file_status st = fs::status(p, ec);
  return fs::exists(st) && !fs::is_directory(st) && (!fs::is_regular_file(st) || inProc(p));
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
// any other output. Errors name the output (`path`), not the hidden temporary name.
fs::path makeTemp(const std::string& path, const fs::path& folder, const std::string& stem, const std::string& ext) {
  std::string name = (folder / ("." + stem + ".oblong-XXXXXX")).string() + ext;
  const int fd = ::mkstemps(name.data(), int(ext.size()));
  if (fd < 0) fail(path, "cannot create a file in folder '{}' ({})", folder.string(), errnoText());
  const mode_t mask = ::umask(0);
  ::umask(mask);
  ::fchmod(fd, 0666 & ~mask);
  ::close(fd);
  return name;
}

}  // namespace

void checkOutputPath(const std::string& path, const std::string& what) {
  if (path.empty()) fail("(empty name)", "the {} output needs a file name", what);
  if (path.find('\0') != std::string::npos) fail("(name with NUL)", "output file names cannot contain NUL");
  const fs::path target = resolve(path);
  std::error_code ec;
  const fs::file_status st = fs::status(target, ec);
  if (ec && ec != std::errc::no_such_file_or_directory)
    fail(path, "cannot write {} ({})", what, ec.message());
  if (fs::is_directory(st)) fail(path, "cannot write {}: is a directory", what);
  if (isDevice(target)) {  // written through
    if (::access(target.c_str(), W_OK) != 0) fail(path, "cannot write {} ({})", what, errnoText());
    return;
  }
  const fs::path folder = folderOf(target);
  if (!fs::is_directory(folder, ec)) fail(path, "cannot write {}: folder '{}' does not exist", what, folder.string());
  if (::access(folder.c_str(), W_OK | X_OK) != 0)
    fail(path, "cannot write {}: folder '{}' is not writable ({})", what, folder.string(), errnoText());
  if (fs::exists(st) && ::access(target.c_str(), W_OK) != 0) fail(path, "cannot write {} ({})", what, errnoText());
  // Permissions do not tell everything (a read-only or special filesystem such as /proc
  // accepts access(W_OK) from root): create the temporary file the write will use.
  std::error_code rm;
  fs::remove(makeTemp(path, folder, target.filename().string(), target.extension().string()), rm);
}

bool writtenThrough(const std::string& path) { return isDevice(resolve(path, false)); }

void checkDistinctOutputs(const std::vector<std::pair<std::string, std::string>>& outputs) {
  for (size_t i = 0; i < outputs.size(); ++i)
    for (size_t j = i + 1; j < outputs.size(); ++j) {
      const auto& [fa, a] = outputs[i];
      const auto& [fb, b] = outputs[j];
      if (a.empty() || b.empty()) continue;
      const fs::path ra = comparable(a), rb = comparable(b);
      // A device (/dev/null, /dev/stdout) may take several outputs.
      if ((ra == rb || sameFile(a, b)) && !isDevice(ra)) fail(b, "{} and {} name the same file", fa, fb);
    }
}

void checkNotInputs(const std::vector<std::pair<std::string, std::string>>& outputs,
                    const std::vector<std::pair<std::string, std::string>>& inputs) {
  for (const auto& [flag, out] : outputs) {
    if (out.empty()) continue;
    const fs::path ro = comparable(out);
    if (isDevice(ro)) continue;
    for (const auto& [what, in] : inputs)
      if (!in.empty() && (sameFile(out, in) || ro == comparable(in, false)))
        fail(out, "{} names an input of this command ({} '{}'): writing it would destroy it", flag, what, in);
  }
}

void writeOutput(const std::string& path, const std::function<void(const std::string&)>& write) {
  const fs::path target = resolve(path);
  const std::string ext = target.extension().string(), stem = target.filename().string();
  std::error_code ec;
  const bool through = isDevice(target);
  std::error_code tec;
  fs::path tmpFolder = through ? fs::temp_directory_path(tec) : folderOf(target);
  if (tec) tmpFolder = "/tmp";
  const fs::path tmp = makeTemp(path, tmpFolder, stem, ext);
  try {
    write(tmp.string());
    if (through) {
      const std::string bytes = slurp(tmp);
      // O_APPEND: standard output redirected with >> keeps what it held (> emptied it).
      const int fd = ::open(target.c_str(), O_WRONLY | O_APPEND | O_CLOEXEC);
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

void writeFileBytes(const std::string& file, const std::string& path, const void* data, size_t n) {
  const int fd = ::open(file.c_str(), O_WRONLY | O_TRUNC | O_CLOEXEC);
  if (fd < 0) fail(path, "cannot open for writing ({})", errnoText());
  writeAllAndClose(fd, path, static_cast<const char*>(data), n);
}

void writeTextOutput(const std::string& path, const std::string& text) {
  writeOutput(path, [&](const std::string& tmp) { writeFileBytes(tmp, path, text.data(), text.size()); });
}

}  // namespace oblong
