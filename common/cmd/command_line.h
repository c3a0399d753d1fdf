// What every rtpm program's command line shares: --version, the exit codes in --help, and usage
// errors that name the program, suggest the flag meant and exit 2.
#pragma once

#include <CLI/CLI.hpp>

#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace rtpm {

/// Exit code of a command line that cannot be used (unknown flag, bad value, out of range),
/// the same in every program.
inline constexpr int kExitUsage = 2;

/// A flag's value that passed the parser but not the program's own checks; main returns kExitUsage.
struct UsageError : std::invalid_argument {
    using std::invalid_argument::invalid_argument;
};

/// What --version prints: program, version, commit and the wire protocol version.
std::string versionText(std::string_view program, unsigned protocolVersion);

/// Edit distance (Levenshtein: insertions, deletions, substitutions) between `a` and `b`.
size_t editDistance(std::string_view a, std::string_view b);

/// The long or short flag of `app` nearest to `given` ("--frmaes" → "--frames"), or "" if none is
/// near enough to be a typo: distance at most 1 for names up to 4 letters, 2 up to 8, 3 beyond.
std::string nearestFlag(const CLI::App& app, std::string_view given);

/// A program's exit codes and what each means, for its --help.
using ExitCodes = std::vector<std::pair<int, std::string>>;

/// Command lines a user can start from, each with what it does, for the end of --help.
using Examples = std::vector<std::pair<std::string, std::string>>;

/// Adds --version (printing versionText), lists `exitCodes` with the one every program shares
/// (kExitUsage), in order, then `examples`, in the --help epilogue, and formats --help with
/// HelpFormatter.
void addStandardFlags(CLI::App& app, unsigned protocolVersion, ExitCodes exitCodes, const Examples& examples = {});

/// CLI11's --help with a flag's range in words: "--max-scene-bytes UINT=536870912  bytes ...,
/// [1, 1099511627776]" where CLI11 prints "UINT:UINT in [1 - 1099511627776]=536870912" (the
/// validators' descriptions glued to the type name), and ">= 0" for a non-negative number.
class HelpFormatter : public CLI::Formatter {
  public:
    std::string make_option_opts(const CLI::Option* opt) const override;
    std::string make_option_desc(const CLI::Option* opt) const override;
};

/// Parses `argv` into `app`. Returns nullopt to go on, or the code main returns at once: 0 after
/// --help or --version, kExitUsage after a usage error, printed to stderr as
/// "<program>: <what is wrong>", a "did you mean --x?" for a mistyped flag, and where to look.
std::optional<int> parseCommandLine(CLI::App& app, int argc, char** argv);

/// Prints a UsageError of `program` the way parseCommandLine prints the parser's; returns kExitUsage.
int reportUsageError(const std::string& program, const UsageError& e);

}  // namespace rtpm
