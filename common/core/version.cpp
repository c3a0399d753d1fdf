// rtpm's version and commit, passed in by CMake (common/core/CMakeLists.txt) to this file alone.
#include "common/core/version.h"

namespace rtpm {

const char* rtpmVersion() { return RTPM_VERSION; }
const char* rtpmCommit() { return RTPM_GIT_COMMIT; }

}  // namespace rtpm
