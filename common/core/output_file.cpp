// Output files: the start-up check of an output path (output_file.h).
#include "common/core/output_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>

namespace rtpm {

std::string temporaryPathBeside(const std::string& path) {
    static std::atomic<uint64_t> counter{0};
    const std::filesystem::path p(path);
    // Appended piece by piece: "." + string trips GCC 12's -Wrestrict false positive (bug 105329).
    std::string name = ".";
    name += p.filename().string();
    name += ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter.fetch_add(1));
    return (p.has_parent_path() ? p.parent_path() / name : std::filesystem::path(name)).string();
}

void prepareOutputFile(const std::string& flag, const std::string& path, OutputWrite how) {
    namespace fs = std::filesystem;
    auto refuse = [&](const std::string& why) { throw OutputError(flag + " " + path + ": " + why); };
    if (path.empty()) refuse("empty path");
    const fs::path p(path);
    const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
    std::error_code ec;
    if (!fs::exists(dir, ec)) {
        fs::create_directories(dir, ec);
        if (ec) refuse("cannot create folder " + dir.string() + ": " + ec.message());
    }
    if (!fs::is_directory(dir, ec)) refuse(dir.string() + " is not a folder");
    const fs::file_status st = fs::symlink_status(p, ec);
    if (fs::exists(st)) {
        const fs::file_status target = fs::status(p, ec);
        if (fs::is_directory(target)) refuse("it is a folder");
        if (!fs::is_regular_file(target)) refuse("it exists and is not a regular file");
        if (how == OutputWrite::Append && ::access(path.c_str(), W_OK) != 0)
            refuse(std::string("cannot append to it: ") + std::strerror(errno));
    }
    // The real test of writability (permissions, read-only mounts, quotas, ACLs, root squash):
    // create, write and remove a file beside it, the way every write will.
    const std::string probe = temporaryPathBeside(path);
    const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) refuse("cannot create a file in " + dir.string() + ": " + std::strerror(errno));
    const char byte = 0;
    const bool wrote = ::write(fd, &byte, 1) == 1;
    const int writeErrno = errno;
    ::close(fd);
    ::unlink(probe.c_str());
    if (!wrote) refuse("cannot write a file in " + dir.string() + ": " + std::strerror(writeErrno));
}

}  // namespace rtpm
