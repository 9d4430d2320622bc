#include "core/input_file.h"

#include "core/error.h"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

namespace oblong {

namespace fs = std::filesystem;

void checkInputFile(const std::string& path) {
  if (path.empty()) fail("(empty name)", "an input file needs a name");
  if (path.find('\0') != std::string::npos) {
    std::string shown = path;
    for (char& c : shown)
      if (c == '\0') c = '?';
    fail(shown, "file name contains a NUL character");
  }
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    const int err = errno;
    struct stat lst {};
    if (err == ENOENT && ::lstat(path.c_str(), &lst) == 0 && S_ISLNK(lst.st_mode))
      fail(path, "file not found (a symbolic link to a missing file)");
    if (err == ENOENT || err == ENOTDIR) fail(path, "file not found");
    if (err == ELOOP) fail(path, "cannot open: a loop of symbolic links");
    fail(path, "cannot open ({})", std::strerror(err));
  }
  if (S_ISDIR(st.st_mode)) fail(path, "not a regular file (a folder)");
  if (!S_ISREG(st.st_mode)) fail(path, "not a regular file");
}

bool sameFile(const std::string& a, const std::string& b) {
  struct stat sa {}, sb {};
  if (::stat(a.c_str(), &sa) != 0 || ::stat(b.c_str(), &sb) != 0) return false;
  return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

}  // namespace oblong
