// Tests of printableText: forged log lines, control bytes, invalid UTF-8, bidi overrides, bounds.
#include "common/core/printable_text.h"

#include <gtest/gtest.h>

#include <random>
#include <string>

namespace rtpm {
namespace {

bool hasControlByte(const std::string& s) {
    for (unsigned char c : s)
        if (c < 0x20 || c == 0x7F) return true;
    return false;
}

TEST(PrintableText, PlainNamesAreKept) {
    EXPECT_EQ(printableText("worker-3.example"), "worker-3.example");
    EXPECT_EQ(printableText("r\xC3\xA9seau \xE6\x97\xA5"), "r\xC3\xA9seau \xE6\x97\xA5");  // UTF-8
    EXPECT_EQ(printableText(""), "");
}

TEST(PrintableText, NewlinesCannotForgeALogLine) {
    const std::string forged =
        "evil\n[2026-11-23 18:00:00.000] [info] client 'ok' joined\r\n\tnext";
    const std::string out = printableText(forged, 1000);
    EXPECT_FALSE(hasControlByte(out)) << out;
    EXPECT_EQ(out.find('\n'), std::string::npos);
    EXPECT_NE(out.find("evil\\n[2026"), std::string::npos) << out;
    EXPECT_NE(out.find("\\r\\n\\tnext"), std::string::npos) << out;
}

TEST(PrintableText, ControlBytesEscapeCodesAndBackslashesAreEscaped) {
    EXPECT_EQ(printableText(std::string("a\0b", 3)), "a\\x00b");
    EXPECT_EQ(printableText("\x1b[31mred"), "\\x1B[31mred");  // terminal escape sequence
    EXPECT_EQ(printableText("\x7f"), "\\x7F");
    EXPECT_EQ(printableText("\xC2\x85"), "\\x85");  // C1 NEL, a newline to some viewers
    EXPECT_EQ(printableText("a\\nb"), "a\\\\nb");   // a literal backslash-n stays distinguishable
}

TEST(PrintableText, InvalidUtf8AndBidiOverridesAreEscaped) {
    EXPECT_EQ(printableText("\xff\xfe"), "\\xFF\\xFE");
    EXPECT_EQ(printableText("\xC0\xAF"), "\\xC0\\xAF");          // overlong '/'
    EXPECT_EQ(printableText("\xED\xA0\x80"), "\\xED\\xA0\\x80");  // surrogate
    EXPECT_EQ(printableText("\xE2\x80\xAE" "txt"), "\\u{202E}txt");  // right-to-left override
    EXPECT_EQ(printableText("a\xE2\x80\xA8" "b"), "a\\u{2028}b");    // line separator
    EXPECT_EQ(printableText("\xE2\x82"), "\\xE2\\x82");              // truncated sequence
}

TEST(PrintableText, LengthIsBoundedAndTheCutIsNamed) {
    const std::string longName(1 << 20, 'x');
    const std::string out = printableText(longName, 64);
    EXPECT_LE(out.size(), 64u + 32u);
    EXPECT_EQ(out.substr(0, 64), std::string(64, 'x'));
    EXPECT_NE(out.find("(+" + std::to_string((1 << 20) - 64) + " bytes)"), std::string::npos) << out;
    // An escape is never cut in half.
    const std::string ctl(100, '\n');
    const std::string cut = printableText(ctl, 7);
    EXPECT_EQ(cut.substr(0, 6), "\\n\\n\\n");
    EXPECT_EQ(cut[6], '\xE2');  // the ellipsis follows three whole escapes
}

TEST(PrintableText, RandomBytesNeverYieldControlBytes) {
    std::mt19937 rng(13);
    for (int t = 0; t < 2000; ++t) {
        std::string s(size_t(rng() % 300), '\0');
        for (char& c : s) c = char(rng());
        const std::string out = printableText(s, 200);
        ASSERT_FALSE(hasControlByte(out));
        ASSERT_LE(out.size(), 200u + 32u);
    }
}

}  // namespace
}  // namespace rtpm
