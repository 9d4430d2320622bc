// Output files of the command line: checked before any work, written so that a failed
// or interrupted write never leaves a truncated file under the final name.
//
// A regular file (or a name that does not exist yet) is written to a temporary file
// beside it and renamed into place once every write and the close succeeded. A name
// that is not a regular file (a device such as /dev/stdout or /dev/full, a FIFO) is
// written through: the content goes to a temporary file first and is then copied into
// it, every write and the close checked. Symbolic links are followed.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace oblong {

// Throws oblong::Error naming `path` when it cannot be an output: empty name, a
// directory, a missing or unwritable folder, an unwritable file. `what` names the
// output in the message ("image", "statistics", ...).
void checkOutputPath(const std::string& path, const std::string& what);

// Whether `path` is written through (a device, a FIFO, standard output through
// /dev/stdout) rather than replaced by a finished temporary file.
bool writtenThrough(const std::string& path);

// Distinct outputs of one command must not name the same file (both would be written).
// `outputs` holds (flag, path) pairs; empty paths are ignored. Compared as files:
// absolute, symbolic links and '..' resolved, hard links by inode.
void checkDistinctOutputs(const std::vector<std::pair<std::string, std::string>>& outputs);

// An output must not be one of the command's inputs (scene, meshes, maps, ray file):
// `inputs` holds (what, path) pairs. Compared as files: links and '..' resolved.
void checkNotInputs(const std::vector<std::pair<std::string, std::string>>& outputs,
                    const std::vector<std::pair<std::string, std::string>>& inputs);

// Writes `path` through `write`, which receives the name of the file to write (a
// temporary one; it keeps path's extension, so image writers pick the same format).
// `write` throws oblong::Error on failure; anything left is removed. Then the file is
// renamed (or copied) into place, which throws oblong::Error naming `path` on failure.
void writeOutput(const std::string& path, const std::function<void(const std::string& tmp)>& write);

// Writes `n` bytes into the existing file `file` (truncating it), every write and the
// close checked; errors name `path`, the output the file stands for.
void writeFileBytes(const std::string& file, const std::string& path, const void* data, size_t n);

// Text content in one go (JSON, CSV): every write and the close are checked.
void writeTextOutput(const std::string& path, const std::string& text);

}  // namespace oblong
