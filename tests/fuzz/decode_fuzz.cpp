// libFuzzer target: every protocol decoder on arbitrary bytes must fail cleanly or round-trip.
#include <cstdio>
#include <cstdlib>

#include "tests/fuzz/decode_check.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string violated = rtpm::proto::testing::checkDecoders(std::span(data, size));
    if (!violated.empty()) {
        std::fprintf(stderr, "decoder property violated: %s\n", violated.c_str());
        std::abort();
    }
    return 0;
}
