// Output files (images, CSV, exported scenes): one check, before any work, that a path can be
// written, and the error that says an output — not the scene or the settings — is the problem.
#pragma once

#include <stdexcept>
#include <string>

namespace rtpm {

/// An output that cannot be written. Its message names the flag, the path and the reason; mains
/// print it as an output error.
struct OutputError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// How a file at an output path is written.
enum class OutputWrite {
    Replace,  ///< written whole (images through a file renamed over the path, exported scenes)
    Append,   ///< opened for appending (CSV figures)
};

/// Checks, before any work is done, that `path` (the value of flag `flag`, e.g. "--csv") can later
/// be written: missing folders are created, a file can be created, written and removed in its
/// folder, the path is not a folder or a non-regular file (a device would be replaced by the
/// rename), and with OutputWrite::Append an existing file is writable. Throws OutputError
/// "<flag> <path>: <reason>". Cost: one small file created and removed.
void prepareOutputFile(const std::string& flag, const std::string& path, OutputWrite how = OutputWrite::Replace);

/// A fresh hidden name in `path`'s folder, unique per process and call, for a file to write and
/// then rename over `path` (or remove).
std::string temporaryPathBeside(const std::string& path);

}  // namespace rtpm
