// SceneFiles: reference resolution inside the allowed folders, regular-file reads, the byte budget.
#include "common/scene/scene_files.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "common/core/printable_text.h"
#include "common/scene/scene.h"

namespace rtpm {

namespace fs = std::filesystem;

namespace {

// Canonical form of `dir`, or empty when it cannot be resolved (then it allows nothing).
fs::path canonicalDir(const fs::path& dir) {
    std::error_code ec;
    fs::path c = fs::canonical(dir.empty() ? fs::path(".") : dir, ec);
    if (ec || !fs::is_directory(c, ec)) return {};
    return c;
}

// Whether `p` equals `root` or lies below it, component by component (so /a/bc is not below /a/b).
bool isWithin(const fs::path& p, const fs::path& root) {
    auto r = root.begin(), q = p.begin();
    for (; r != root.end(); ++r, ++q) {
        if (r->empty() && std::next(r) == root.end()) return true;  // trailing separator
        if (q == p.end() || *q != *r) return false;
    }
    return true;
}

std::string mib(uint64_t bytes) { return std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB"; }

}  // namespace

SceneFiles::SceneFiles(const std::string& sceneFile, const SceneInputPolicy& policy)
    : SceneFiles(sceneFile,
                 fs::path(sceneFile).has_parent_path() ? fs::path(sceneFile).parent_path().string()
                                                       : std::string("."),
                 policy) {}

SceneFiles::SceneFiles(const std::string& sceneName, const std::string& baseDir,
                       const SceneInputPolicy& policy)
    : sceneFile_(sceneName), limit_(std::max<uint64_t>(policy.maxSceneBytes, 1)) {
    if (!baseDir.empty()) {
        baseDir_ = canonicalDir(baseDir);
        if (!baseDir_.empty()) roots_.push_back(baseDir_);
    }
    // Extra folders only widen a scene that has a folder of its own; an in-memory scene without
    // one reads no files at all.
    if (!baseDir_.empty())
        for (const std::string& d : policy.allowedDirs) {
            fs::path c = canonicalDir(d);
            if (!c.empty()) roots_.push_back(c);
        }
}

bool SceneFiles::allowed(const fs::path& canonical) const {
    for (const fs::path& root : roots_)
        if (isWithin(canonical, root)) return true;
    return false;
}

fs::path SceneFiles::resolve(const std::string& reference, const std::string& element) const {
    std::string shown = "'";
    shown += printableText(reference);
    shown += '\'';
    if (reference.empty()) throw SceneError(sceneFile_, element, "empty file reference");
    // A NUL would end the path for the kernel but not for the checks below; control bytes
    // have no place in a file name a scene refers to.
    for (unsigned char c : reference)
        if (c < 0x20 || c == 0x7F)
            throw SceneError(sceneFile_, element, "file reference " + shown + " holds a control byte");
    const std::string refused = "file reference " + shown +
                                " lies outside the scene's folder; allow a folder with "
                                "--allow-scene-dir";
    if (roots_.empty())
        throw SceneError(sceneFile_, element,
                         "file reference " + shown + " refused: the scene was given without a folder");
    fs::path p(reference);
    if (p.is_relative()) p = baseDir_ / p;
    std::error_code ec;
    // weakly_canonical follows every symlink of the part that exists (so `link/..` is resolved
    // the way the kernel does), then normalises the rest lexically.
    fs::path c = fs::weakly_canonical(p, ec);
    if (ec) c = p.lexically_normal();
    if (ec || !allowed(c)) throw SceneError(sceneFile_, element, refused);
    return c;
}

bool SceneFiles::exists(const fs::path& resolved) {
    struct stat st;
    return ::stat(resolved.c_str(), &st) == 0;
}

void SceneFiles::charge(uint64_t bytes, const std::string& element) {
    if (bytes > limit_ - std::min(used_, limit_))
        throw SceneError(sceneFile_, element,
                         "scene needs more than --max-scene-bytes " + std::to_string(limit_) +
                             " (" + mib(limit_) + ") of file data and decoded arrays (" +
                             std::to_string(used_) + " used, " + std::to_string(bytes) +
                             " more asked)");
    used_ += bytes;
}

std::vector<uint8_t> SceneFiles::read(const fs::path& resolved, const std::string& element) {
    return readRegularFile(resolved, sceneFile_, element, [&](uint64_t size) { charge(size, element); });
}

std::vector<uint8_t> readRegularFile(const fs::path& path, const std::string& fileName,
                                     const std::string& element,
                                     const std::function<void(uint64_t size)>& admit) {
    // Non-blocking open: a FIFO must not wait for a writer; then fstat on the open descriptor
    // decides, so the file checked is the file read.
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
    if (fd < 0)
        throw SceneError(fileName, element,
                         errno == ENOENT ? "file not found" : std::string("cannot open file: ") +
                                                                  std::strerror(errno));
    struct Closer {
        int fd;
        ~Closer() { ::close(fd); }
    } closer{fd};
    struct stat st;
    if (::fstat(fd, &st) != 0) throw SceneError(fileName, element, "cannot read file");
    if (!S_ISREG(st.st_mode))
        throw SceneError(fileName, element,
                         S_ISDIR(st.st_mode) ? "is a folder, not a file"
                                             : "not a regular file (FIFO, device or socket)");
    const uint64_t size = uint64_t(st.st_size);
    admit(size);
    std::vector<uint8_t> bytes(size_t(size), 0);
    size_t got = 0;
    while (got < bytes.size()) {
        ssize_t n = ::read(fd, bytes.data() + got, bytes.size() - got);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) throw SceneError(fileName, element, std::string("read error: ") + std::strerror(errno));
        if (n == 0) break;  // shrank while reading
        got += size_t(n);
    }
    bytes.resize(got);
    return bytes;
}

}  // namespace rtpm
