// Display tone mapping with a vectorisable fit of the sRGB transfer curve.
#include "common/image/tone_map.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <immintrin.h>

#include "common/core/check.h"
#include "common/image/image_io.h"

namespace rtpm {


float displayScale(std::span<const float> rgb, float exposureStops, size_t stride) {
    std::vector<float> scratch;
    return displayScale(rgb, exposureStops, stride, scratch);
}

float displayScale(std::span<const float> rgb, float exposureStops, size_t stride, std::vector<float>& scratch) {
    // autoExposureScale's 99th percentile of luminance over every stride-th pixel, in `scratch`.
    const size_t n = rgb.size() / 3;
    if (stride < 1) stride = 1;
    scratch.clear();
    for (size_t i = 0; i < n; i += stride) {
        const float* p = rgb.data() + 3 * i;
        const float l = 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2];
        scratch.push_back(std::isfinite(l) ? l : 0.0f);
    }
    float s = 1.0f;
    if (!scratch.empty()) {
        const size_t m = scratch.size();
        const size_t k = std::min(m - 1, size_t(std::floor(0.99 * double(m - 1) + 0.5)));
        std::nth_element(scratch.begin(), scratch.begin() + std::ptrdiff_t(k), scratch.end());
        const float p99 = scratch[k];
        s = p99 > 0.0f && std::isfinite(1.0f / p99) ? 1.0f / p99 : 1.0f;
    }
    s *= std::exp2(exposureStops);
    return std::isfinite(s) && s > 0.0f ? s : 1.0f;
}

namespace {

// The sRGB curve above the linear toe as three nested square roots (Ian Taylor's fit of
// x^(1/2.4)): every operation has a SIMD form, so the loop vectorises (a table lookup does not),
// and the fit stays within one 8-bit step of the exact curve (tests/unit/image).
// Portable path (AVX2 clone where the CPU has it, SSE2 otherwise).
__attribute__((target_clones("avx2", "default")))
void toneMapSqrt(const float* in, uint8_t* o, size_t n, float scale) {
    for (size_t i = 0; i < n; ++i) {
        float x = in[i] * scale;
        x = x > 0.0f ? x : 0.0f;  // also maps NaN to 0 (the comparison is false)
        x = x < 1.0f ? x : 1.0f;  // and +Inf to 1
        const float s1 = std::sqrt(x), s2 = std::sqrt(s1), s3 = std::sqrt(s2);
        const float curve = 0.585122381f * s1 + 0.783140355f * s2 - 0.368262736f * s3;
        float v = x <= 0.0031308f ? 12.92f * x : curve;
        v = v < 1.0f ? v : 1.0f;
        o[i] = uint8_t(int(255.0f * v + 0.5f));
    }
}

// Eight values: tone-mapped to 0…255 in 32-bit lanes.
__attribute__((target("avx2,fma"))) inline __m256i toneMap8(const float* p, __m256 vs) {
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
    const __m256 toe = _mm256_set1_ps(0.0031308f), slope = _mm256_set1_ps(12.92f);
    const __m256 c1 = _mm256_set1_ps(0.585122381f), c2 = _mm256_set1_ps(0.783140355f), c3 = _mm256_set1_ps(-0.368262736f);
    const __m256 k255 = _mm256_set1_ps(255.0f), half = _mm256_set1_ps(0.5f);
    __m256 x = _mm256_mul_ps(_mm256_loadu_ps(p), vs);
    x = _mm256_max_ps(x, zero);  // NaN → 0 (max returns the second operand on NaN)
    x = _mm256_min_ps(x, one);   // +Inf → 1
    const __m256 xc = _mm256_max_ps(x, toe);  // the curve's input stays > 0 (rsqrt(0) = inf)
    const __m256 s1 = _mm256_mul_ps(xc, _mm256_rsqrt_ps(xc));
    const __m256 s2 = _mm256_mul_ps(s1, _mm256_rsqrt_ps(s1));
    const __m256 s3 = _mm256_mul_ps(s2, _mm256_rsqrt_ps(s2));
    const __m256 curve = _mm256_fmadd_ps(c1, s1, _mm256_fmadd_ps(c2, s2, _mm256_mul_ps(c3, s3)));
    __m256 v = _mm256_blendv_ps(curve, _mm256_mul_ps(slope, x), _mm256_cmp_ps(x, toe, _CMP_LE_OQ));
    v = _mm256_min_ps(v, one);
    return _mm256_cvttps_epi32(_mm256_fmadd_ps(v, k255, half));
}

// The same fit with AVX2 + FMA intrinsics, square roots as x · rsqrt(x) (one approximate
// reciprocal square root, 1.5·2^-12 relative error, instead of a full-precision divide-class
// sqrt: the three roots were the loop's whole cost). 32 values per iteration, packed to bytes.
__attribute__((target("avx2,fma"))) void toneMapAvx2(const float* in, uint8_t* o, size_t n, float scale) {
    const __m256 vs = _mm256_set1_ps(scale);
    const __m256i order = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
    size_t i = 0;
    for (; i + 32 <= n; i += 32) {
        const __m256i a = toneMap8(in + i, vs), b = toneMap8(in + i + 8, vs), c = toneMap8(in + i + 16, vs), d = toneMap8(in + i + 24, vs);
        const __m256i bytes = _mm256_packus_epi16(_mm256_packus_epi32(a, b), _mm256_packus_epi32(c, d));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(o + i), _mm256_permutevar8x32_epi32(bytes, order));
    }
    if (i < n) toneMapSqrt(in + i, o + i, n - i, scale);
}

}  // namespace

void toneMapSrgb8(std::span<const float> rgb, float scale, std::span<uint8_t> out) {
    RTPM_CHECK(out.size() == rgb.size());
    static const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    if (avx2) toneMapAvx2(rgb.data(), out.data(), rgb.size(), scale);
    else toneMapSqrt(rgb.data(), out.data(), rgb.size(), scale);
}

}  // namespace rtpm
