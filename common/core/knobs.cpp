// Limits, text forms and the reset rule of the settings, all read from kKnobs and kFixedSettings.
#include "common/core/knobs.h"

#include <charconv>
#include <cmath>

namespace rtpm {

namespace {

constexpr bool rowFitsItsDefault(const SettingRow& r) {
    const RenderSettings defaults{};
    return r.min <= r.max && r.get(defaults) == r.defaultValue && r.defaultValue >= r.min &&
           r.defaultValue <= r.max && (r.form == FlagForm::Value || (r.integer && r.min == 0 && r.max == 1));
}

constexpr bool rowsInOrderWithTheirDefaults() {
    for (size_t i = 0; i < kKnobCount; ++i) {
        const KnobRow& r = kKnobs[i];
        if (size_t(r.id) != i || !rowFitsItsDefault(r) || r.form != FlagForm::Value) return false;
        // A knob the clients never see may change only what the master's output stage does.
        if (r.wire == WireType::None && r.resets != KnobReset::Output) return false;
    }
    for (const SettingRow& r : kFixedSettings)
        if (!rowFitsItsDefault(r) || r.wire == WireType::None) return false;
    return true;
}
static_assert(rowsInOrderWithTheirDefaults(),
              "kKnobs in Knob order; every row: min <= default <= max, default = RenderSettings{}'s, a "
              "switch 0 or 1; a live knob off the wire resets only Output, a fixed setting has a wire type");

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

std::optional<std::string> knobValueError(const SettingRow& row, double v) {
    const bool whole = !row.integer || std::floor(v) == v;
    if (std::isfinite(v) && whole && v >= row.min && v <= row.max) return std::nullopt;
    return std::string(row.name) + " must be " + (row.isChoice() ? "" : row.integer ? "a whole number in " : "in ") +
           knobRange(row) + ", got " + (row.isChoice() ? number(v) : number(v));
}

std::optional<double> parseKnobValue(const SettingRow& row, std::string_view text) {
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

std::string formatKnobValue(const SettingRow& row, double v) {
    if (row.isChoice()) {
        const size_t i = size_t(v);
        return i < row.choices.size() && !row.choices[i].empty() ? std::string(row.choices[i]) : number(v);
    }
    return number(v);
}

std::string knobRange(const SettingRow& row) {
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
