// The shared command-line conventions: the flag suggested for a typo, the exit codes in --help,
// --version's text, and usage errors that return 2 (issue 24, items 3 and 4).
#include "common/cmd/command_line.h"

#include <gtest/gtest.h>

#include <memory>

#include "common/core/version.h"

namespace rtpm {
namespace {

TEST(CommandLine, EditDistanceCountsInsertionsDeletionsAndSubstitutions) {
    EXPECT_EQ(editDistance("", ""), 0u);
    EXPECT_EQ(editDistance("frames", "frames"), 0u);
    EXPECT_EQ(editDistance("frmaes", "frames"), 2u);  // a swap is two substitutions
    EXPECT_EQ(editDistance("frame", "frames"), 1u);
    EXPECT_EQ(editDistance("kitten", "sitting"), 3u);
    EXPECT_EQ(editDistance("", "abc"), 3u);
}

std::unique_ptr<CLI::App> exampleApp() {
    auto app = std::make_unique<CLI::App>("example", "rtpm-example");
    static int frames = 0, width = 0, k = 0, photons = 0;
    app->add_option("--frames", frames);
    app->add_option("--width", width);
    app->add_option("--k", k);
    app->add_option("--photons,-P", photons);
    return app;
}

TEST(CommandLine, NearestFlagSuggestsOnlyNearMisses) {
    const auto app = exampleApp();
    EXPECT_EQ(nearestFlag(*app, "--frmaes"), "--frames");
    EXPECT_EQ(nearestFlag(*app, "--frame=3"), "--frames");
    EXPECT_EQ(nearestFlag(*app, "--widht"), "--width");
    EXPECT_EQ(nearestFlag(*app, "--photon"), "--photons");
    EXPECT_EQ(nearestFlag(*app, "--kk"), "--k");
    EXPECT_EQ(nearestFlag(*app, "--threads"), "");  // nothing near: no guess
    EXPECT_EQ(nearestFlag(*app, "-Q"), "");         // a one-letter flag is never "near" another
    EXPECT_EQ(nearestFlag(*app, "--"), "");
}

int parse(CLI::App& app, std::vector<std::string> args) {
    args.insert(args.begin(), "rtpm-example");
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    return parseCommandLine(app, int(argv.size()), argv.data()).value_or(-1);
}

TEST(CommandLine, UsageErrorsReturnTwoHelpAndVersionZero) {
    const auto app = exampleApp();
    addStandardFlags(*app, 3, {{0, "done"}, {1, "failed"}}, {});
    EXPECT_EQ(parse(*app, {"--frames", "3"}), -1);  // go on
    EXPECT_EQ(parse(*exampleApp(), {"--frmaes", "3"}), kExitUsage);
    EXPECT_EQ(parse(*exampleApp(), {"--frames", "three"}), kExitUsage);
    const auto version = exampleApp();
    addStandardFlags(*version, 3, {}, {});
    EXPECT_EQ(parse(*version, {"--version"}), 0);
    EXPECT_EQ(app->get_footer(), "Exit codes:\n  0  done\n  1  failed\n  2  usage error: unknown flag, bad or "
                                "out-of-range value");
}

// --help shows a checked flag's type, default and range in words. CLI11 alone prints the validators'
// descriptions glued to the type ("--bytes UINT:UINT in [1 - 1099511627776]=536870912",
// "--wait FLOAT:NONNEGATIVE=30").
TEST(CommandLine, HelpShowsRangesInWordsAndExamplesAfterTheExitCodes) {
    CLI::App app("example", "rtpm-example");
    uint64_t bytes = 536870912;
    double wait = 30;
    int threads = 0;
    app.add_option("--bytes", bytes, "bytes to read")->capture_default_str()->check(
        CLI::Range(uint64_t(1), uint64_t(1) << 40));
    app.add_option("--wait", wait, "seconds to wait")->capture_default_str()->check(CLI::NonNegativeNumber);
    app.add_option("--threads", threads, "threads, [0, 4096]")->capture_default_str()->check(CLI::Range(0, 4096));
    addStandardFlags(app, 3, {{0, "done"}}, {{"rtpm-example --bytes 5", "reads 5 bytes"}});
    const std::string help = app.help();
    EXPECT_NE(help.find("--bytes UINT=536870912"), std::string::npos) << help;
    EXPECT_NE(help.find("bytes to read, [1, 1099511627776]"), std::string::npos) << help;
    EXPECT_NE(help.find("--wait FLOAT=30"), std::string::npos) << help;
    EXPECT_NE(help.find("seconds to wait, >= 0"), std::string::npos) << help;
    EXPECT_NE(help.find("threads, [0, 4096]\n"), std::string::npos) << help;  // said once, not twice
    EXPECT_EQ(help.find(" in ["), std::string::npos) << help;
    EXPECT_EQ(help.find("NONNEGATIVE"), std::string::npos) << help;
    EXPECT_NE(help.find("  2  usage error: unknown flag, bad or out-of-range value\n\nExamples:\n"
                        "  rtpm-example --bytes 5\n      reads 5 bytes"),
              std::string::npos)
        << help;
}

TEST(CommandLine, VersionTextNamesVersionCommitAndProtocol) {
    EXPECT_EQ(versionText("rtpm-x", 3),
              std::string("rtpm-x ") + rtpmVersion() + "\ncommit " + rtpmCommit() + "\nprotocol version 3");
}

}  // namespace
}  // namespace rtpm
