// The master's output stage on hostile but well-formed pixel data: values that would overflow the
// composed image are clamped and counted, never +Inf in the EXR (issue 13: 3e38 accepted, 10 680 of
// 19 200 pixels written as 0 after overflowing).
#include "server/image_output.h"

#include <gtest/gtest.h>

#include <cmath>

#include "proto/pixel_codec.h"

namespace rtpm::server {
namespace {

proto::FrameData setData(const Interleave& pattern, uint32_t set, float value) {
    std::vector<proto::PixelPair> px(size_t(pattern.pixelCount(int(set))));
    for (auto& p : px)
        for (int c = 0; c < 3; ++c) p.direct[c] = p.caustic[c] = value;
    proto::FrameData d;
    d.frame = 0;
    d.set = set;
    d.encoding = proto::PixelEncoding::Float32;
    d.pixelCount = uint32_t(px.size());
    d.pixels = proto::encodePixels(px, proto::PixelEncoding::Float32).bytes;
    return d;
}

/// A quiet output stage of `width`×`height` pixels, M = 2, box filter `filter`.
ImageOutputOptions smallOutput(int width, int height, int filter) {
    ImageOutputOptions o;
    o.width = width;
    o.height = height;
    o.interleave = 2;
    o.filter = filter;
    o.quiet = true;
    return o;
}

TEST(ImageOutputStage, OverflowingRadianceIsClampedAndCountedNeverInf) {
    const ImageOutputOptions o = smallOutput(24, 16, 2);
    ImageOutput output(o);
    const Interleave pattern{o.width, o.height, o.interleave};
    OutputJob job;
    job.setCount = 4;
    job.owners = {1, 1, 2, 2};
    for (uint32_t s = 0; s < 4; ++s) job.data.push_back(setData(pattern, s, s == 2 ? 3e38f : 0.5f));
    const OutputResult r = output.process(job);
    EXPECT_TRUE(r.badPayloads.empty());
    EXPECT_EQ(r.clampedValues, uint64_t(pattern.pixelCount(2)) * 6);
    for (const auto* buf : {&output.image().final(), &output.image().direct(), &output.image().causticFiltered()})
        for (float v : *buf) ASSERT_TRUE(std::isfinite(v)) << v;
    // Honest values pass untouched (the cluster's float32 image stays bit-identical).
    OutputJob honest;
    honest.setCount = 4;
    honest.owners = {1, 1, 2, 2};
    for (uint32_t s = 0; s < 4; ++s) honest.data.push_back(setData(pattern, s, 0.5f));
    EXPECT_EQ(output.process(honest).clampedValues, 0u);
    EXPECT_EQ(output.image().direct()[0], 0.5f);
}

// A set off its turn sends no pixels and names the frame that sent them: the master shows the
// pixels it scattered then and decodes nothing; one naming a frame whose pixels it never showed
// (they came late) leaves the set as it is and is counted; new pixels are decoded as ever.
TEST(ImageOutputStage, UnchangedPixelsShowWhatTheirFrameScattered) {
    const ImageOutputOptions o = smallOutput(12, 8, 1);
    ImageOutput output(o);
    const Interleave pattern{o.width, o.height, o.interleave};
    auto frame = [&](uint64_t number, float set0) {
        OutputJob job;
        job.setCount = 4;
        job.owners = {1, 1, 2, 2};
        for (uint32_t s = 0; s < 4; ++s) {
            job.data.push_back(setData(pattern, s, s == 0 ? set0 : 0.25f));
            job.data.back().frame = number;
        }
        return job;
    };
    auto unchanged = [&](OutputJob job, uint64_t sameAs) {
        job.data[0].unchanged = true;
        job.data[0].sameAs = sameAs;
        job.data[0].pixels.clear();
        return job;
    };
    auto set0Direct = [&] { return output.image().direct()[0]; };  // pixel (0, 0) is set 0's
    OutputJob first = frame(3, 0.5f);
    EXPECT_TRUE(output.process(first).badPayloads.empty());
    EXPECT_EQ(set0Direct(), 0.5f);
    OutputJob same = unchanged(frame(4, 0.0f), 3);
    OutputResult r = output.process(same);
    EXPECT_TRUE(r.badPayloads.empty());
    EXPECT_EQ(r.unmatchedUnchanged, 0u);
    EXPECT_EQ(set0Direct(), 0.5f) << "frame 3's pixels stay";
    OutputJob next = frame(5, 0.75f);
    output.process(next);
    EXPECT_EQ(set0Direct(), 0.75f) << "new pixels are decoded";
    OutputJob late = unchanged(frame(7, 0.0f), 6);  // frame 6's pixels never reached the stage
    r = output.process(late);
    EXPECT_TRUE(r.badPayloads.empty());
    EXPECT_EQ(r.unmatchedUnchanged, 1u);
    EXPECT_EQ(set0Direct(), 0.75f) << "the set keeps what it shows";
    OutputJob broken = frame(8, 0.5f);
    broken.data[0].pixels.pop_back();
    EXPECT_EQ(output.process(broken).badPayloads.size(), 1u);
    OutputJob afterBroken = unchanged(frame(9, 0.0f), 8);
    EXPECT_EQ(output.process(afterBroken).unmatchedUnchanged, 1u) << "pixels that failed to decode were not shown";
}

}  // namespace
}  // namespace rtpm::server
