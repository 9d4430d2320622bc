// Input files are checked before a library opens them: a FIFO would block, a device
// never ends, and the filesystem's own errors (a symbolic link loop, a denied folder)
// must become one line naming the file, not an exception without a file name.
#pragma once

#include <string>

namespace oblong {

// Throws oblong::Error naming `path` unless it names a readable regular file (symbolic
// links followed): an empty name, a NUL character in the name, a missing file, a
// dangling link, a link loop, an inaccessible folder, a directory, a device or FIFO.
void checkInputFile(const std::string& path);

// The same file as `a` and `b` name (links followed, relative names against the current
// folder); false when either cannot be resolved.
bool sameFile(const std::string& a, const std::string& b);

}  // namespace oblong
