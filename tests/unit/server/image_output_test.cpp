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

TEST(ImageOutputStage, OverflowingRadianceIsClampedAndCountedNeverInf) {
    ImageOutputOptions o;
    o.width = 24;
    o.height = 16;
    o.interleave = 2;
    o.filter = 2;
    o.quiet = true;
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

}  // namespace
}  // namespace rtpm::server
