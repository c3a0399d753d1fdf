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

// A set off its turn sends the payload of its last frame again: the master shows the pixels it
// scattered then, and any other payload (a new pass, or bytes that fail to decode) is not mistaken
// for a repeat.
TEST(ImageOutputStage, ARepeatedPayloadShowsThePixelsScatteredBefore) {
    const ImageOutputOptions o = smallOutput(12, 8, 1);
    ImageOutput output(o);
    const Interleave pattern{o.width, o.height, o.interleave};
    auto frame = [&](float set0, std::vector<uint8_t> weights0 = {}) {
        OutputJob job;
        job.setCount = 4;
        job.owners = {1, 1, 2, 2};
        for (uint32_t s = 0; s < 4; ++s) job.data.push_back(setData(pattern, s, s == 0 ? set0 : 0.25f));
        job.data[0].ownWeights = std::move(weights0);
        return job;
    };
    auto set0Direct = [&] { return output.image().direct()[0]; };  // pixel (0, 0) is set 0's
    OutputJob first = frame(0.5f);
    EXPECT_TRUE(output.process(first).badPayloads.empty());
    EXPECT_EQ(set0Direct(), 0.5f);
    OutputJob repeat = frame(0.5f);
    EXPECT_TRUE(output.process(repeat).badPayloads.empty());
    EXPECT_EQ(set0Direct(), 0.5f);
    OutputJob next = frame(0.75f);
    output.process(next);
    EXPECT_EQ(set0Direct(), 0.75f) << "new bytes are decoded";
    const size_t n = size_t(pattern.pixelCount(0));
    OutputJob weighted = frame(0.75f, std::vector<uint8_t>(n, 255));
    output.process(weighted);
    EXPECT_EQ(output.image().causticFiltered()[0], 0.75f) << "the same pixels with other weights are new";
    OutputJob broken = frame(0.75f);
    broken.data[0].pixels.pop_back();
    EXPECT_EQ(output.process(broken).badPayloads.size(), 1u);
    OutputJob again = frame(0.75f);
    EXPECT_TRUE(output.process(again).badPayloads.empty());
    EXPECT_EQ(set0Direct(), 0.75f);
}

}  // namespace
}  // namespace rtpm::server
