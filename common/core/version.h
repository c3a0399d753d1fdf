// rtpm's version and the git commit it was built from, for --version and image metadata.
#pragma once

namespace rtpm {

/// rtpm's version (CMake's project version), e.g. "0.1.0".
const char* rtpmVersion();

/// The git commit the build was configured from (12-digit short hash, with "-dirty" when the
/// tree had uncommitted changes then), or "unknown" outside a git checkout. Read when CMake
/// configures, not at every build.
const char* rtpmCommit();

}  // namespace rtpm
