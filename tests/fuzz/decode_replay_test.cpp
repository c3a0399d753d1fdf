// Bounded fuzzing that runs under any compiler: random and mutated byte strings through every
// decoder (the libFuzzer target runs the same checks when clang is available).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>

#include "tests/fuzz/decode_check.h"

namespace rtpm::proto {
namespace {

std::vector<std::vector<uint8_t>> seeds() {
    std::vector<std::vector<uint8_t>> out;
    for (const Message& m : testing::sampleMessages()) out.push_back(encode(m));
    return out;
}

TEST(DecodeFuzz, SampleMessagesKeepEveryDecoderProperty) {
    const auto all = seeds();
    for (const auto& s : all) EXPECT_EQ(testing::checkDecoders(s), "");
    // ctest sets this to seed the libFuzzer corpus with one valid message of every type.
    if (const char* dir = std::getenv("RTPM_FUZZ_CORPUS_DIR")) {
        std::filesystem::create_directories(dir);
        for (size_t i = 0; i < all.size(); ++i) {
            std::ofstream f(std::filesystem::path(dir) / ("seed_" + std::to_string(i)),
                            std::ios::binary);
            f.write(reinterpret_cast<const char*>(all[i].data()),
                    static_cast<std::streamsize>(all[i].size()));
            ASSERT_TRUE(f.good()) << dir;
        }
    }
}

TEST(DecodeFuzz, RandomBytesNeverBreakTheDecoders) {
    std::mt19937 rng(20240601);
    for (int i = 0; i < 20000; ++i) {
        std::vector<uint8_t> b(rng() % 96);
        for (auto& v : b) v = static_cast<uint8_t>(rng());
        // Half the inputs get a valid header prefix so the payload decoders are reached.
        if (i % 2 == 0 && b.size() >= kHeaderBytes) {
            Writer w;
            encodeHeader(Header{kMagic, kProtocolVersion,
                                static_cast<MessageType>(1 + rng() % kMaxMessageType), 0,
                                static_cast<uint32_t>(b.size() - kHeaderBytes)},
                         w);
            std::copy(w.data().begin(), w.data().end(), b.begin());
        }
        ASSERT_EQ(testing::checkDecoders(b), "") << "input " << i;
    }
}

TEST(DecodeFuzz, MutatedMessagesNeverBreakTheDecoders) {
    // Byte flips, bit flips, insertions, deletions and length-field splats on valid messages:
    // the cheap half of what libFuzzer does, bounded so it runs in well under a second.
    std::mt19937 rng(7);
    const auto base = seeds();
    const uint8_t splat[] = {0x00, 0xFF, 0x7F, 0x80};
    for (int i = 0; i < 30000; ++i) {
        std::vector<uint8_t> b = base[rng() % base.size()];
        const int edits = 1 + static_cast<int>(rng() % 4);
        for (int e = 0; e < edits && !b.empty(); ++e) {
            const size_t at = rng() % b.size();
            switch (rng() % 5) {
                case 0: b[at] = static_cast<uint8_t>(rng()); break;
                case 1: b[at] ^= static_cast<uint8_t>(1u << (rng() % 8)); break;
                case 2: b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), static_cast<uint8_t>(rng())); break;
                case 3: b.erase(b.begin() + static_cast<std::ptrdiff_t>(at)); break;
                case 4:
                    for (size_t k = at; k < std::min(b.size(), at + 4); ++k) b[k] = splat[rng() % 4];
                    break;
            }
        }
        ASSERT_EQ(testing::checkDecoders(b), "") << "mutation " << i;
    }
}

}  // namespace
}  // namespace rtpm::proto
