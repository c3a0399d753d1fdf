// Peer- and file-supplied strings made safe for a log line: control bytes escaped, length bounded.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace rtpm {

/// Default bound of printableText, in output bytes before the truncation note.
constexpr size_t kPrintableTextMaxBytes = 120;

/// Returns `text` fit for one log line: C0 controls, DEL and C1 controls are written as `\n`,
/// `\r`, `\t` or `\xHH`; a backslash as `\\`; bytes that are not valid UTF-8 as `\xHH`; Unicode
/// bidirectional overrides and line/paragraph separators (U+2028/9, U+202A–E, U+2066–9) as
/// `\u{HHHH}`. Valid printable UTF-8 is kept. At most `maxBytes` bytes of escaped text are
/// kept (never cutting an escape or a UTF-8 sequence); a cut adds `…(+N bytes)` naming how many
/// input bytes were dropped. The result never contains a byte below 0x20 or 0x7F.
/// Thread-safe (pure). Cost O(min(|text|, maxBytes)).
std::string printableText(std::string_view text, size_t maxBytes = kPrintableTextMaxBytes);

}  // namespace rtpm
