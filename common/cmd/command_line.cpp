// The shared command-line conventions of rtpm's programs (command_line.h).
#include "common/cmd/command_line.h"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <numeric>
#include <regex>
#include <vector>

#include "common/core/version.h"

namespace rtpm {

std::string versionText(std::string_view program, unsigned protocolVersion) {
    return std::string(program) + " " + rtpmVersion() + "\ncommit " + rtpmCommit() + "\nprotocol version " +
           std::to_string(protocolVersion);
}

size_t editDistance(std::string_view a, std::string_view b) {
    // One row of the Wagner–Fischer table at a time.
    std::vector<size_t> row(b.size() + 1);
    std::iota(row.begin(), row.end(), size_t(0));
    for (size_t i = 1; i <= a.size(); ++i) {
        size_t diagonal = row[0];
        row[0] = i;
        for (size_t j = 1; j <= b.size(); ++j) {
            const size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = up;
        }
    }
    return row[b.size()];
}

std::string nearestFlag(const CLI::App& app, std::string_view given) {
    const std::string_view name = given.substr(0, given.find('='));
    const std::string_view bare = name.substr(std::min(name.find_first_not_of('-'), name.size()));
    if (bare.size() < 2) return "";  // "-Q" is no typo of anything in particular
    const size_t allowed = bare.size() <= 4 ? 1 : bare.size() <= 8 ? 2 : 3;
    std::string best;
    size_t bestDistance = allowed + 1;
    for (const CLI::Option* opt : app.get_options()) {
        std::vector<std::string> names;
        for (const std::string& l : opt->get_lnames()) names.push_back("--" + l);
        for (const std::string& s : opt->get_snames()) names.push_back("-" + s);
        for (const std::string& candidate : names) {
            const std::string_view candidateBare =
                std::string_view(candidate).substr(candidate.find_first_not_of('-'));
            const size_t d = editDistance(bare, candidateBare);
            const bool shortFlag = candidate[1] != '-';  // "-P": one letter off is another flag
            if (d < bestDistance && !(shortFlag && d > 0)) {
                bestDistance = d;
                best = candidate;
            }
        }
    }
    return best;
}

void addStandardFlags(CLI::App& app, unsigned protocolVersion, ExitCodes exitCodes, const Examples& examples) {
    const std::string program = app.get_name();
    app.set_version_flag("--version", [program, protocolVersion] { return versionText(program, protocolVersion); },
                         "print the version, the git commit and the protocol version, and exit");
    app.formatter(std::make_shared<HelpFormatter>());
    exitCodes.emplace_back(kExitUsage, "usage error: unknown flag, bad or out-of-range value");
    std::sort(exitCodes.begin(), exitCodes.end());
    std::string footer = "Exit codes:";
    for (const auto& [code, meaning] : exitCodes) footer += "\n  " + std::to_string(code) + "  " + meaning;
    if (!examples.empty()) footer += "\n\nExamples:";
    for (const auto& [command, what] : examples) footer += "\n  " + command + "\n      " + what;
    app.footer(footer);
}

namespace {

/// An option's type name without the validators' descriptions CLI11 appends to it after colons.
std::string bareTypeName(const CLI::Option* opt) {
    const std::string full = opt->get_type_name();
    return full.substr(0, full.find(':'));
}

/// The validators' descriptions in words: "INT in [0 - 4096]" → "[0, 4096]", "NONNEGATIVE" → ">= 0".
std::string rangeInWords(const CLI::Option* opt) {
    const std::string full = opt->get_type_name();
    std::string words;
    for (size_t at = full.find(':'); at != std::string::npos;) {
        const size_t next = full.find(':', at + 1);
        const std::string part = full.substr(at + 1, next == std::string::npos ? std::string::npos : next - at - 1);
        at = next;
        static const std::regex range(R"(\S+ in \[(.+) - (.+)\])");
        std::smatch m;
        std::string text = part;
        if (std::regex_match(part, m, range))
            text = "[" + m[1].str() + ", " + m[2].str() + "]";
        else if (part == "NONNEGATIVE")
            text = ">= 0";
        else if (part == "POSITIVE")
            text = "> 0";
        words += (words.empty() ? "" : ", ") + text;
    }
    return words;
}

}  // namespace

std::string HelpFormatter::make_option_opts(const CLI::Option* opt) const {
    if (!opt->get_option_text().empty() || opt->get_type_size() == 0 || opt->get_type_name().find(':') == std::string::npos)
        return CLI::Formatter::make_option_opts(opt);
    // CLI::Formatter's own text with the bare type name (its other parts are kept as they are).
    const std::string full = CLI::Formatter::make_option_opts(opt);
    const std::string glued = " " + opt->get_type_name();
    const size_t at = full.find(glued);
    if (at == std::string::npos) return full;
    return full.substr(0, at) + " " + bareTypeName(opt) + full.substr(at + glued.size());
}

std::string HelpFormatter::make_option_desc(const CLI::Option* opt) const {
    const std::string description = CLI::Formatter::make_option_desc(opt);
    const std::string range = rangeInWords(opt);
    if (range.empty() || description.find(range) != std::string::npos) return description;
    return description + (description.empty() ? "" : ", ") + range;
}

namespace {

void printUsageHint(const std::string& program) {
    std::fprintf(stderr, "%s: run '%s --help' for the flags and their ranges\n", program.c_str(), program.c_str());
}

}  // namespace

std::optional<int> parseCommandLine(CLI::App& app, int argc, char** argv) {
    try {
        app.parse(argc, argv);
        return std::nullopt;
    } catch (const CLI::CallForHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForAllHelp& e) {
        return app.exit(e);
    } catch (const CLI::CallForVersion& e) {
        return app.exit(e);
    } catch (const CLI::ParseError& e) {
        const std::string& program = app.get_name();
        std::fprintf(stderr, "%s: %s\n", program.c_str(), e.what());
        // Every word that looks like a flag the program does not know gets its nearest flag.
        for (int i = 1; i < argc; ++i) {
            const std::string arg = argv[i];
            if (arg.size() < 2 || arg[0] != '-' || arg == "--" || (arg[1] >= '0' && arg[1] <= '9') || arg[1] == '.')
                continue;
            const std::string name = arg.substr(0, arg.find('='));
            if (app.get_option_no_throw(name) != nullptr) continue;
            const std::string near = nearestFlag(app, name);
            std::fprintf(stderr, "%s: unknown flag %s%s\n", program.c_str(), name.c_str(),
                         near.empty() ? "" : (": did you mean " + near + "?").c_str());
        }
        printUsageHint(program);
        return kExitUsage;
    }
}

int reportUsageError(const std::string& program, const UsageError& e) {
    std::fprintf(stderr, "%s: %s\n", program.c_str(), e.what());
    printUsageHint(program);
    return kExitUsage;
}

}  // namespace rtpm
