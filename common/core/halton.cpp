// Radical inverses, the rotated Halton sequence and the hash behind every non-Halton random number.
#include "common/core/halton.h"

#include <cmath>
#include <utility>

#include "common/core/check.h"

namespace rtpm {

double radicalInverseBase2(uint64_t index) {
    uint64_t v = index;
    v = ((v >> 1) & 0x5555555555555555ull) | ((v & 0x5555555555555555ull) << 1);
    v = ((v >> 2) & 0x3333333333333333ull) | ((v & 0x3333333333333333ull) << 2);
    v = ((v >> 4) & 0x0F0F0F0F0F0F0F0Full) | ((v & 0x0F0F0F0F0F0F0F0Full) << 4);
    v = ((v >> 8) & 0x00FF00FF00FF00FFull) | ((v & 0x00FF00FF00FF00FFull) << 8);
    v = ((v >> 16) & 0x0000FFFF0000FFFFull) | ((v & 0x0000FFFF0000FFFFull) << 16);
    v = (v >> 32) | (v << 32);
    // Keep 53 bits so the conversion is exact and the result stays below 1.
    return static_cast<double>(v >> 11) * 0x1p-53;
}

namespace {

// The base is a template parameter so every division below is by a constant (a multiply and a
// shift): Halton sampling is a third of photon-tracing time otherwise (paper Table 3).
template <uint64_t kBase>
double radicalInverseOf(uint64_t index) {
    // Accumulate the mirrored digits as an integer (exact) and divide once by b^n, so that for
    // b^n < 2^53 the result is the exact rational rounded once; stop before `reversed` could
    // overflow 53 bits (further digits are below double precision anyway).
    uint64_t reversed = 0;
    uint64_t denominator = 1;  // b^n while exact in a double
    double scale = 1.0;        // the remaining 1 / b^m beyond that
    while (index > 0 && reversed < (uint64_t{1} << 52) / kBase) {
        const uint64_t next = index / kBase;
        reversed = reversed * kBase + (index - next * kBase);
        if (denominator <= (uint64_t{1} << 53) / kBase) {
            denominator *= kBase;
        } else {
            scale /= static_cast<double>(kBase);
        }
        index = next;
    }
    const double r = static_cast<double>(reversed) / static_cast<double>(denominator) * scale;
    return r < 1.0 ? r : 0x1.fffffffffffffp-1;
}

template <size_t... kDims>
double dispatch(int dim, uint64_t index, std::index_sequence<kDims...>) {
    using Fn = double (*)(uint64_t);
    static constexpr Fn kTable[] = {&radicalInverseOf<kHaltonPrimes[kDims]>...};
    return kTable[dim](index);
}

}  // namespace

double radicalInverse(int dim, uint64_t index) {
    RTPM_DCHECK(dim >= 0 && dim < kHaltonMaxDims);
    if (dim == 0) return radicalInverseBase2(index);
    return dispatch(dim, index, std::make_index_sequence<kHaltonPrimes.size()>{});
}

float radicalInverseBase3f(uint32_t index) {
    const float inv = 1.0f / 3.0f;
    float f = inv, r = 0.0f;
    while (index > 0) {
        r += f * float(index % 3);
        index /= 3;
        f *= inv;
    }
    return r;
}

uint64_t mixBits(uint64_t v) {
    v ^= v >> 30;
    v *= 0xbf58476d1ce4e5b9ull;
    v ^= v >> 27;
    v *= 0x94d049bb133111ebull;
    v ^= v >> 31;
    return v;
}

uint64_t hashKeys(uint64_t a, uint64_t b, uint64_t c, uint64_t d, uint64_t e) {
    // Each key is folded in after a full mix, so (a, b) and (b, a) hash differently.
    uint64_t h = mixBits(a + 0x9e3779b97f4a7c15ull);
    h = mixBits(h ^ (b + 0x632be59bd9b4e019ull));
    h = mixBits(h ^ (c + 0x85157af5ull));
    h = mixBits(h ^ (d + 0x7a646e4d9c8e3b2full));
    h = mixBits(h ^ (e + 0x1d8e4e27c47d124full));
    return h;
}

Halton::Halton(uint64_t seed, uint64_t stream) {
    for (int d = 0; d < kHaltonMaxDims; ++d) {
        rotation_[static_cast<size_t>(d)] =
            static_cast<double>(hashKeys(seed, stream, static_cast<uint64_t>(d), 0x48414c54ull) >> 11) *
            0x1p-53;
    }
}

float Halton::sample(int dim, uint64_t index) const {
    double x = radicalInverse(dim, index) + rotation_[static_cast<size_t>(dim)];
    if (x >= 1.0) x -= 1.0;
    const float f = static_cast<float>(x);
    return f < kOneMinusEpsilon ? f : kOneMinusEpsilon;
}

}  // namespace rtpm
