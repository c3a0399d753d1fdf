// rtpm-server's command line: rtpm-render's rendering flags plus the cluster's, declared on a
// CLI::App (the --help groups cluster, viewer, security, output) and checked into MasterOptions.
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include "common/render/render_flags.h"
#include "common/scene/scene_loader.h"
#include "server/master.h"

namespace rtpm::server {

/// What the flags hold before they become MasterOptions: the values given as text or in other
/// units, and the scene flags the master's options do not carry. Filled by the parse.
struct ServerFlags {
    bool noDefaultLight = false;
    SceneInputPolicy sceneInput;
    SceneOverrides overrides;
    ConvergenceFlags convergence;
    std::string animate, editScript;
    std::string encoding = "rgb9e5-zstd";
    std::string deadline = "auto";
    int handshakeMs = 0, readMs = 0;
    CLI::Option* frames = nullptr;  ///< --frames, to tell a default from a given value
};

/// Declares every rtpm-server flag on `app`, writing into `o` and `flags` (whose numeric
/// defaults it takes from `o`). The order is --help's.
void addServerFlags(CLI::App& app, MasterOptions& o, ServerFlags& flags);

/// After the parse: checks what the parser cannot (ranges, spellings, the token, the rendering
/// settings) and completes `o` from `flags`. Throws UsageError naming the flag.
void applyServerFlags(const ServerFlags& flags, MasterOptions& o);

}  // namespace rtpm::server
