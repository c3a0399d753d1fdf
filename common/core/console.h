// How every rtpm program writes to its console: one line at a time, as it happens.
#pragma once

namespace rtpm {

/// Makes stdout line-buffered. Call first thing in main, before any output. C makes stdout fully
/// buffered when it is not a terminal (a pipe, a file, CI, a container's log), so a program's
/// lines would reach a reader in 4 KiB blocks or only at exit; with this each line is written
/// when it ends. stderr stays unbuffered, as C starts it: each fprintf reaches it whole and at once.
void lineBufferConsole();

}  // namespace rtpm
