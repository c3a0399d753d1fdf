// Nothing rendered is lost to the file system: images replace their file through a temporary
// file and a rename; an unwritable --out, --csv or --export-glb, or an --out that is neither .exr
// nor .png, is refused before rendering as an output error (issue 13, item 5; issue 24, item 1).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "common/core/output_file.h"
#include "common/image/image_io.h"

namespace rtpm {
namespace {

namespace fs = std::filesystem;

class ScratchDir {
public:
    ScratchDir() {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        path_ = fs::temp_directory_path() / ("rtpm_out_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
        fs::remove_all(path_);
        fs::create_directories(path_);
    }
    ~ScratchDir() {
        std::error_code ec;
        fs::remove_all(path_, ec);
    }
    fs::path operator/(const std::string& name) const { return path_ / name; }
    const fs::path& path() const { return path_; }

private:
    fs::path path_;
};

std::vector<float> constant(int w, int h, float v) { return std::vector<float>(size_t(w * h * 3), v); }

std::string readAll(std::FILE* f) {
    std::string out;
    char buf[4096];
    std::rewind(f);
    for (size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) out.append(buf, n);
    return out;
}

size_t entries(const fs::path& dir) {
    size_t n = 0;
    for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
    return n;
}

TEST(ImageOutput, WritesReplaceTheFileByRenameNeverInPlace) {
    ScratchDir dir;
    const std::string path = (dir / "frame.exr").string();
    const std::vector<float> first = constant(16, 8, 0.25f), second = constant(16, 8, 0.75f);
    writeExr(path, 16, 8, std::vector<ImageLayer>{{"", first}});
    // A reader that opened the old image keeps reading a whole old image (its inode), while the
    // path now names a whole new one: the write went to another file that was renamed over it.
    std::FILE* reader = std::fopen(path.c_str(), "rb");
    ASSERT_NE(reader, nullptr);
    const std::string before = readAll(reader);
    struct stat oldStat {};
    ASSERT_EQ(::stat(path.c_str(), &oldStat), 0);
    writeExr(path, 16, 8, std::vector<ImageLayer>{{"", second}});
    struct stat newStat {};
    ASSERT_EQ(::stat(path.c_str(), &newStat), 0);
    EXPECT_NE(oldStat.st_ino, newStat.st_ino);
    EXPECT_EQ(readAll(reader), before);
    std::fclose(reader);
    EXPECT_FLOAT_EQ(readExr(path).layerRgb("")[0], 0.75f);
    writePng((dir / "frame.png").string(), 16, 8, second);
    EXPECT_EQ(entries(dir.path()), 2u) << "a temporary file was left behind";
}

TEST(ImageOutput, AFailedWriteLeavesTheOldImageAndNoTemporaryFile) {
    ScratchDir dir;
    const std::string path = (dir / "frame.exr").string();
    const std::vector<float> good = constant(4, 4, 0.5f);
    writeExr(path, 4, 4, std::vector<ImageLayer>{{"", good}});
    // The folder becomes a file's place that cannot be renamed over: a folder at the target.
    const std::string blocked = (dir / "blocked.exr").string();
    fs::create_directories(blocked);
    EXPECT_THROW(writeExr(blocked, 4, 4, std::vector<ImageLayer>{{"", good}}), std::runtime_error);
    EXPECT_TRUE(fs::is_directory(blocked));
    EXPECT_FLOAT_EQ(readExr(path).layerRgb("")[0], 0.5f);
    EXPECT_EQ(entries(dir.path()), 2u) << "a temporary file was left behind";
}

std::string refusal(const std::string& path) {
    try {
        prepareOutputFile("--out", path);
    } catch (const OutputError& e) {
        return e.what();
    }
    return "";
}

TEST(ImageOutput, UnwritableDestinationsAreRefusedWithTheReason) {
    ScratchDir dir;
    // Fine: an existing folder, a folder to create, an existing image to replace.
    EXPECT_EQ(refusal((dir / "a.exr").string()), "");
    EXPECT_EQ(refusal((dir / "new/sub/a.exr").string()), "");
    EXPECT_TRUE(fs::is_directory(dir / "new/sub"));
    std::ofstream(dir / "old.png") << "x";
    EXPECT_EQ(refusal((dir / "old.png").string()), "");
    EXPECT_EQ(entries(dir.path()), 2u) << "the probe file was left behind";
    // Refused (these hold for root too, which ignores permission bits): a folder no file can be
    // created in, a path whose folder is a file, a folder at the path.
    std::ofstream(dir / "file") << "x";
    // A FIFO (or a device) at the path: the rename would replace it.
    ASSERT_EQ(::mkfifo((dir / "fifo.exr").c_str(), 0600), 0);
    EXPECT_NE(refusal((dir / "fifo.exr").string()).find("not a regular file"), std::string::npos);
    const std::string cases[][2] = {
        {"/proc/rtpm_issue13.exr", "cannot create a file in /proc"},
        {(dir / "file/a.exr").string(), "folder"},
        {(dir / "new").string() + ".exr", "it is a folder"},
        {"/sys/rtpm_issue13.exr", "cannot create a file in /sys"},
    };
    fs::create_directories(dir / "new.exr");
    for (const auto& c : cases) {
        const std::string err = refusal(c[0]);
        EXPECT_NE(err, "") << c[0];
        EXPECT_NE(err.find(c[0]), std::string::npos) << err;
        EXPECT_NE(err.find(c[1]), std::string::npos) << err;
    }
    if (::geteuid() != 0) {  // permission bits only bind other users
        fs::create_directories(dir / "ro");
        fs::permissions(dir / "ro", fs::perms::owner_read | fs::perms::owner_exec);
        EXPECT_NE(refusal((dir / "ro/a.exr").string()), "");
        fs::permissions(dir / "ro", fs::perms::owner_all);
    }
}

TEST(ImageOutput, RenderRefusesAnUnwritableOutBeforeRendering) {
    const std::string exe = std::string(RTPM_BINARY_DIR) + "/common/cmd/rtpm-render";
    if (!fs::exists(exe)) GTEST_SKIP() << "rtpm-render not built in " << RTPM_BINARY_DIR;
    ScratchDir dir;
    const std::string log = (dir / "log.txt").string();
    // Before: 200 frames rendered, then "cannot write images" (the result lost).
    const std::string cmd = exe + " --scene RING --width 32 --height 24 --frames 200 --out /proc/rtpm_issue13/x.exr > " +
                            log + " 2>&1";
    const int status = std::system(cmd.c_str());
    ASSERT_TRUE(WIFEXITED(status));
    EXPECT_NE(WEXITSTATUS(status), 0);
    std::ifstream in(log);
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string out = ss.str();
    EXPECT_NE(out.find("rtpm-render: output error: --out /proc/rtpm_issue13/x.exr: cannot"), std::string::npos)
        << out;
    EXPECT_EQ(out.find("interaction"), std::string::npos) << "frames were rendered first:\n" << out;
}

TEST(ImageOutput, OutNamesAnExrAndAPngBesideItOrIsRefused) {
    // Before: --out ring.png wrote the EXR, then the PNG over it; --out x.jpg wrote an EXR named x.jpg.
    for (const char* given : {"out/ring.exr", "out/ring.png", "out/ring.EXR"}) {
        const ImageOutputPaths p = imageOutputPaths(given);
        EXPECT_EQ(p.exr, "out/ring.exr") << given;
        EXPECT_EQ(p.png, "out/ring.png") << given;
    }
    for (const char* given : {"x.jpg", "x", "dir.exr/x.tiff"}) {
        try {
            imageOutputPaths(given);
            ADD_FAILURE() << given << " accepted";
        } catch (const OutputError& e) {
            EXPECT_NE(std::string(e.what()).find(std::string("--out ") + given + ": "), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("ending in .exr"), std::string::npos) << e.what();
        }
    }
    // A folder gets a file name in it as the example (before: "e.g. outdir/.exr").
    const ScratchDir dir;
    for (const std::string& given : {std::string("outdir/"), dir.path().string()}) {
        try {
            imageOutputPaths(given);
            ADD_FAILURE() << given << " accepted";
        } catch (const OutputError& e) {
            const std::string example = (fs::path(given) / "image.exr").lexically_normal().string();
            EXPECT_NE(std::string(e.what()).find("names a folder"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("e.g. " + example), std::string::npos) << e.what();
        }
    }
}

TEST(ImageOutput, CsvOutputsGetTheirFolderAndAnUnappendableFileIsRefused) {
    ScratchDir dir;
    EXPECT_NO_THROW(prepareOutputFile("--csv", (dir / "a/b/figures.csv").string(), OutputWrite::Append));
    EXPECT_TRUE(fs::is_directory(dir / "a/b"));
    fs::create_directories(dir / "folder.csv");
    try {
        prepareOutputFile("--csv", (dir / "folder.csv").string(), OutputWrite::Append);
        ADD_FAILURE() << "a folder accepted as a CSV file";
    } catch (const OutputError& e) {
        EXPECT_NE(std::string(e.what()).find("--csv " + (dir / "folder.csv").string() + ": it is a folder"),
                  std::string::npos)
            << e.what();
    }
}

// Runs rtpm-render with `args`; returns its exit code, stdout+stderr in `out`.
int runRender(const std::string& args, const std::string& log, std::string& out) {
    const std::string exe = std::string(RTPM_BINARY_DIR) + "/common/cmd/rtpm-render";
    const int status = std::system((exe + " " + args + " > " + log + " 2>&1").c_str());
    std::ifstream in(log);
    std::stringstream ss;
    ss << in.rdbuf();
    out = ss.str();
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(ImageOutput, RenderChecksEveryOutputBeforeRenderingAndCreatesTheirFolders) {
    const std::string exe = std::string(RTPM_BINARY_DIR) + "/common/cmd/rtpm-render";
    if (!fs::exists(exe)) GTEST_SKIP() << "rtpm-render not built in " << RTPM_BINARY_DIR;
    ScratchDir dir;
    const std::string log = (dir / "log.txt").string();
    const std::string tiny = " --scene RING --width 16 --height 12 -M 2 -P 200 --frames 1";
    std::string out;
    // Refused at start-up, as an output error, before a frame: a JPEG name, a CSV into /proc.
    EXPECT_EQ(runRender(tiny + " --out " + (dir / "x.jpg").string(), log, out), 1) << out;
    EXPECT_NE(out.find("rtpm-render: output error: --out " + (dir / "x.jpg").string()), std::string::npos) << out;
    EXPECT_EQ(out.find("interaction"), std::string::npos) << out;
    EXPECT_EQ(runRender(tiny + " --out " + (dir / "a.exr").string() + " --csv /proc/rtpm/f.csv", log, out), 1) << out;
    EXPECT_NE(out.find("rtpm-render: output error: --csv /proc/rtpm/f.csv: cannot create folder"), std::string::npos)
        << out;
    EXPECT_EQ(out.find("interaction"), std::string::npos) << out;
    EXPECT_FALSE(fs::exists(dir / "a.exr"));
    // Accepted: --out NAME.png writes NAME.exr and NAME.png; --csv and --export-glb into new folders.
    EXPECT_EQ(runRender(tiny + " --out " + (dir / "img/ring.png").string() + " --csv " +
                            (dir / "figures/run.csv").string(),
                        log, out),
              0)
        << out;
    EXPECT_TRUE(fs::is_regular_file(dir / "img/ring.exr")) << out;
    EXPECT_TRUE(fs::is_regular_file(dir / "img/ring.png")) << out;
    EXPECT_NO_THROW(readExr((dir / "img/ring.exr").string())) << "the EXR was overwritten by the PNG";
    EXPECT_TRUE(fs::is_regular_file(dir / "figures/run.csv")) << out;
    EXPECT_EQ(runRender(" --scene RING --export-glb " + (dir / "scenes/ring.glb").string(), log, out), 0) << out;
    EXPECT_TRUE(fs::is_regular_file(dir / "scenes/ring.glb")) << out;
}

}  // namespace
}  // namespace rtpm
