// Limits, text forms and the reset rule of the live knobs, all read from kKnobs.
#include "common/core/knobs.h"

#include <charconv>
#include <cmath>

namespace rtpm {

namespace {

constexpr bool rowsInOrderWithTheirDefaults() {
    const RenderSettings defaults{};
    for (size_t i = 0; i < kKnobCount; ++i) {
        const KnobRow& r = kKnobs[i];
        if (size_t(r.id) != i || r.min > r.max || r.get(defaults) != r.defaultValue) return false;
        if (r.defaultValue < r.min || r.defaultValue > r.max) return false;
    }
    return true;
}
static_assert(rowsInOrderWithTheirDefaults(),
              "kKnobs: rows in Knob order, min <= default <= max, default = RenderSettings{}'s");

// The shortest fixed-point text that reads back to `v`; as a float when `v` is one (a value read
// back from a float field prints as "0.3", not "0.300000012").
std::string number(double v) {
    char buf[400];
    const float f = float(v);
    const auto [end, ec] = double(f) == v ? std::to_chars(buf, buf + sizeof buf, f, std::chars_format::fixed)
                                          : std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed);
    return ec == std::errc() ? std::string(buf, end) : std::string("?");
}

}  // namespace

std::optional<std::string> knobValueError(const KnobRow& row, double v) {
    const bool whole = !row.integer || std::floor(v) == v;
    if (std::isfinite(v) && whole && v >= row.min && v <= row.max) return std::nullopt;
    return std::string(row.name) + " must be " + (row.isChoice() ? "" : row.integer ? "a whole number in " : "in ") +
           knobRange(row) + ", got " + (row.isChoice() ? number(v) : number(v));
}

std::optional<double> parseKnobValue(const KnobRow& row, std::string_view text) {
    if (row.isChoice()) {
        for (size_t i = 0; i < row.choices.size() && !row.choices[i].empty(); ++i)
            if (text == row.choices[i]) return double(i);
        return std::nullopt;
    }
    double v = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(v)) return std::nullopt;
    return v;
}

std::string formatKnobValue(const KnobRow& row, double v) {
    if (row.isChoice()) {
        const size_t i = size_t(v);
        return i < row.choices.size() && !row.choices[i].empty() ? std::string(row.choices[i]) : number(v);
    }
    return number(v);
}

std::string knobRange(const KnobRow& row) {
    if (!row.isChoice()) return "[" + number(row.min) + ", " + number(row.max) + "]";
    std::string s;
    for (std::string_view c : row.choices)
        if (!c.empty()) s += (s.empty() ? "" : "|") + std::string(c);
    return s;
}

std::optional<KnobReset> knobChangeReset(const RenderSettings& before, const RenderSettings& after) {
    std::optional<KnobReset> reset;
    for (const KnobRow& r : kKnobs)
        if (r.get(before) != r.get(after) && (!reset || r.resets > *reset)) reset = r.resets;
    return reset;
}

}  // namespace rtpm
