// The settings tables: rows agree with RenderSettings, text forms round-trip, limits and the reset rule.
#include "common/core/knobs.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <stdexcept>
#include <string>

namespace rtpm {
namespace {

TEST(Knobs, EveryRowNamesItsFlagKeysAndDefault) {
    std::set<std::string_view> flags, scriptKeys, viewerKeys;
    const RenderSettings defaults;
    for (const KnobRow& row : kKnobs) {
        EXPECT_TRUE(flags.insert(row.flag).second) << row.flag;
        EXPECT_TRUE(scriptKeys.insert(row.scriptKey).second) << row.scriptKey;
        EXPECT_TRUE(viewerKeys.insert(row.viewerKey).second) << row.viewerKey;
        EXPECT_EQ(row.get(defaults), row.defaultValue) << row.name;
        EXPECT_FALSE(row.group.empty());
        // Off the wire only when the clients need not know it: the master's output alone changes.
        EXPECT_TRUE(row.wire != WireType::None || row.resets == KnobReset::Output) << row.name;
        // set() then get() gives a value within the limits back at both limits (a float field
        // holds the nearest float, which formats back to the same text).
        RenderSettings s;
        for (double v : {row.min, row.max}) {
            row.set(s, v);
            EXPECT_FALSE(knobValueError(row, row.get(s))) << row.name;
            EXPECT_EQ(formatKnobValue(row, row.get(s)), formatKnobValue(row, v)) << row.name;
        }
    }
}

TEST(Knobs, FixedSettingRowsAgreeWithRenderSettingsAndNoFlagIsTwice) {
    std::set<std::string_view> flags;
    for (const KnobRow& row : kKnobs) flags.insert(row.flag);
    const RenderSettings defaults;
    for (const SettingRow& row : kFixedSettings) {
        EXPECT_TRUE(flags.insert(row.flag).second) << row.flag;
        EXPECT_EQ(row.get(defaults), row.defaultValue) << row.name;
        EXPECT_FALSE(row.group.empty()) << row.name;
        EXPECT_NE(row.wire, WireType::None) << row.name;
        RenderSettings s;
        for (double v : {row.min, row.max}) {
            row.set(s, v);
            EXPECT_EQ(row.get(s), v) << row.name;
        }
    }
    // The limits validateSettings applies are the rows': one past a limit is refused by name.
    RenderSettings s;
    s.eye.maxDepth = 65;
    try {
        validateSettings(s);
        ADD_FAILURE() << "eye depth 65 accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("eye depth must be a whole number in [0, 64], got 65"), std::string::npos)
            << e.what();
    }
}

TEST(Knobs, ExposureIsALiveKnobOfTheOutputAlone) {
    const KnobRow& row = knobRow(Knob::Exposure);
    EXPECT_EQ(row.flag, "--exposure");
    EXPECT_EQ(row.resets, KnobReset::Output);
    EXPECT_EQ(row.wire, WireType::None);
    EXPECT_FALSE(knobValueError(row, -20));
    EXPECT_FALSE(knobValueError(row, 1.5));
    EXPECT_TRUE(knobValueError(row, 20.5));
    RenderSettings a, b;
    b.exposure = 2.0f;
    EXPECT_EQ(knobChangeReset(a, b), KnobReset::Output);  // no new epoch, no Settings to clients
}

TEST(Knobs, ValuesRoundTripThroughTheirText) {
    for (const KnobRow& row : kKnobs)
        for (double v : {row.min, row.defaultValue, row.max}) {
            const auto back = parseKnobValue(row, formatKnobValue(row, v));
            ASSERT_TRUE(back) << row.name << " " << formatKnobValue(row, v);
            EXPECT_EQ(*back, v) << row.name;
        }
    EXPECT_EQ(formatKnobValue(knobRow(Knob::Tree), 2), "grid");
    EXPECT_EQ(*parseKnobValue(knobRow(Knob::Estimator), "knn"), double(CausticEstimatorKind::Knn));
    EXPECT_FALSE(parseKnobValue(knobRow(Knob::Estimator), "sppm"));
    EXPECT_FALSE(parseKnobValue(knobRow(Knob::K), "32x"));
    EXPECT_FALSE(parseKnobValue(knobRow(Knob::K), "inf"));
    // A float field's value prints as typed, not with the float's binary tail.
    RenderSettings s;
    knobRow(Knob::RMax).set(s, 0.3);
    EXPECT_EQ(formatKnobValue(knobRow(Knob::RMax), knobRow(Knob::RMax).get(s)), "0.3");
    EXPECT_EQ(formatKnobValue(knobRow(Knob::Photons), 50'000'000), "50000000");
}

TEST(Knobs, OneCeilingPerKnobRefusedByValidation) {
    EXPECT_FALSE(knobValueError(knobRow(Knob::Photons), 50'000'000));
    EXPECT_TRUE(knobValueError(knobRow(Knob::Photons), 0));  // the flag's floor is everyone's
    EXPECT_FALSE(knobValueError(knobRow(Knob::Confidence), 0.001));
    EXPECT_TRUE(knobValueError(knobRow(Knob::Confidence), 0));
    EXPECT_TRUE(knobValueError(knobRow(Knob::Confidence), 16.5));
    EXPECT_TRUE(knobValueError(knobRow(Knob::Photons), 50'000'001));
    EXPECT_TRUE(knobValueError(knobRow(Knob::K), 0));
    EXPECT_TRUE(knobValueError(knobRow(Knob::K), 2.5));
    EXPECT_TRUE(knobValueError(knobRow(Knob::RMax), std::nan("")));
    EXPECT_FALSE(knobValueError(knobRow(Knob::RMax), 0.125));
    const std::string m = *knobValueError(knobRow(Knob::Interleave), 17);
    EXPECT_NE(m.find("interleave M"), std::string::npos) << m;
    EXPECT_NE(m.find("[1, 16]"), std::string::npos) << m;
    RenderSettings s;
    s.photons.k = 4097;
    EXPECT_THROW(validateSettings(s), std::invalid_argument);
    s.photons.k = 4096;
    EXPECT_NO_THROW(validateSettings(s));
}

TEST(Knobs, SettingsDescribeTheLiveKnobsAsTheirFlags) {
    RenderSettings s;
    s.photons.rMax = 0.3f;
    s.photons.progressiveGamma = 0.75f;
    const std::string d = describeSettings(s);
    EXPECT_NE(d.find("-M 3 -F 3 -P 20000 --k 64 --rmax 0.3 --tree middle --estimator progressive --confidence 0.75"),
              std::string::npos)
        << d;
}

TEST(Knobs, AChangeResetsWhatItsRowSays) {
    const RenderSettings a;
    RenderSettings b = a;
    EXPECT_FALSE(knobChangeReset(a, b));
    b.filter = 5;
    EXPECT_EQ(knobChangeReset(a, b), KnobReset::Output);
    b.photons.rMax = 0.5f;
    EXPECT_EQ(knobChangeReset(a, b), KnobReset::Epoch);
    RenderSettings g = a;
    g.photons.progressiveGamma = 1.0f;  // clients rebuild their progressive state
    EXPECT_EQ(knobChangeReset(a, g), KnobReset::Epoch);
    b.interleave = 4;
    EXPECT_EQ(knobChangeReset(a, b), KnobReset::Resize);
    RenderSettings c = a;
    c.photons.seed = 7;  // not a live knob
    EXPECT_FALSE(knobChangeReset(a, c));
}

}  // namespace
}  // namespace rtpm
