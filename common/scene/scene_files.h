// Confined, bounded access to the files a scene names: its own folder (plus folders the user
// allows), regular files only, and every byte read or decoded counted against one budget.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace rtpm {

/// Reads the regular file at `path` whole. It is opened non-blocking (a FIFO never waits for a
/// writer) and refused unless fstat on the open descriptor says it is a regular file; `admit`
/// gets its size before anything is allocated and throws to refuse it. Throws
/// SceneError{fileName, element, …} (not found, not a regular file, read error).
std::vector<uint8_t> readRegularFile(const std::filesystem::path& path, const std::string& fileName,
                                     const std::string& element,
                                     const std::function<void(uint64_t size)>& admit);

/// Default of --max-scene-bytes: bytes a scene may read from files plus decode into arrays.
/// 512 MiB holds a scene of about 5 million triangles with its files; loading peaks at a few
/// times the budget (tinygltf's copies), which a render node can afford.
constexpr uint64_t kDefaultMaxSceneBytes = uint64_t(512) << 20;

/// What a scene file may reach and how much it may decode (flags --allow-scene-dir,
/// --max-scene-bytes). The scene file's own folder is always allowed.
struct SceneInputPolicy {
    std::vector<std::string> allowedDirs;            ///< further folders files may come from
    uint64_t maxSceneBytes = kDefaultMaxSceneBytes;  ///< budget of SceneFiles, > 0
};

/// One scene load's view of the file system.
///
/// Every reference a scene file makes (glTF buffer/image URI after percent-decoding, OBJ
/// `mtllib`, MTL `map_*`) is resolved against the scene file's folder, normalised with every
/// symlink followed (std::filesystem::weakly_canonical) and refused unless the result lies inside
/// the scene's folder or a folder of SceneInputPolicy::allowedDirs. Only regular files are read
/// (no FIFO, device or directory), opened non-blocking, and never more bytes than the budget has
/// left. Errors name the reference as the scene file wrote it, never anything found outside
/// the allowed folders (not its existence, type or size).
///
/// The budget counts bytes read from files plus bytes of decoded arrays the loaders announce
/// with charge() before allocating them; loading stops with a SceneError naming
/// --max-scene-bytes once it would be exceeded. Not thread-safe (one per load).
class SceneFiles {
public:
    /// For the scene file at `sceneFile` (any folder: the user named it).
    SceneFiles(const std::string& sceneFile, const SceneInputPolicy& policy);
    /// For a scene held in memory named `sceneName`, with no folder: every file reference is
    /// refused unless `baseDir` is non-empty, which then plays the scene folder's role.
    SceneFiles(const std::string& sceneName, const std::string& baseDir,
               const SceneInputPolicy& policy);

    /// Name of the scene file in errors (as the user gave it).
    const std::string& sceneFile() const { return sceneFile_; }
    /// Canonical scene folder, empty when there is none.
    const std::filesystem::path& baseDir() const { return baseDir_; }

    /// Resolves `reference` (a path relative to the scene folder, or absolute). Throws
    /// SceneError{sceneFile, element, …} when it holds a control byte or resolves outside every
    /// allowed folder. The returned path is canonical; it need not exist.
    std::filesystem::path resolve(const std::string& reference, const std::string& element) const;

    /// Whether `resolved` (from resolve()) names an existing file system entry.
    static bool exists(const std::filesystem::path& resolved);

    /// Reads the regular file at `resolved` (from resolve(), or the scene file itself) whole,
    /// charging its size to the budget first. Throws SceneError naming `element` when it is not a
    /// regular file, cannot be read or does not fit the budget.
    std::vector<uint8_t> read(const std::filesystem::path& resolved, const std::string& element);

    /// Counts `bytes` the caller is about to allocate against the budget (saturating);
    /// throws SceneError naming `element` and --max-scene-bytes when it would be exceeded.
    void charge(uint64_t bytes, const std::string& element);

    uint64_t used() const { return used_; }
    uint64_t limit() const { return limit_; }

private:
    bool allowed(const std::filesystem::path& canonical) const;

    std::string sceneFile_;
    std::filesystem::path baseDir_;
    std::vector<std::filesystem::path> roots_;  // canonical allowed folders (scene's first)
    uint64_t limit_ = kDefaultMaxSceneBytes;
    uint64_t used_ = 0;
};

}  // namespace rtpm
