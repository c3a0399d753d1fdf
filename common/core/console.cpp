#include "common/core/console.h"

#include <cstdio>

namespace rtpm {

void lineBufferConsole() { std::setvbuf(stdout, nullptr, _IOLBF, 0); }

}  // namespace rtpm
