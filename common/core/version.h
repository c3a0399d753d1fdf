// rtpm's version, the git commit it was built from and its wire protocol's version, for --version
// and image metadata.
#pragma once

#include <cstdint>

namespace rtpm {

/// The wire protocol's version (proto/PROTOCOL.md §2), bumped on any change of a message layout.
/// Kept here, below every program, so that each one's --version names it (rtpm-render and
/// rtpm-compare speak no protocol); proto::kProtocolVersion is this number.
inline constexpr uint16_t kWireProtocolVersion = 11;

/// rtpm's version (CMake's project version), e.g. "0.1.0".
const char* rtpmVersion();

/// The git commit the build was configured from (12-digit short hash, with "-dirty" when the
/// tree had uncommitted changes then), or "unknown" outside a git checkout. Read when CMake
/// configures, not at every build.
const char* rtpmCommit();

}  // namespace rtpm
