// Halton sequences with per-set Cranley–Patterson rotation, and hashed random numbers for photon tracing.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace rtpm {

/// The first primes, the bases of Halton dimensions 0, 1, 2, … (pairwise coprime, as Halton needs).
inline constexpr std::array<uint32_t, 16> kHaltonPrimes = {2,  3,  5,  7,  11, 13, 17, 19,
                                                           23, 29, 31, 37, 41, 43, 47, 53};
inline constexpr int kHaltonMaxDims = static_cast<int>(kHaltonPrimes.size());

/// Largest float below 1: every [0, 1) sample is clamped to it so float rounding never yields 1.
inline constexpr float kOneMinusEpsilon = 0x1.fffffep-1f;

/// Radical inverse Φ_b(i) in base `kHaltonPrimes[dim]`: the base-b digits of i mirrored about the
/// radix point (docs/ARCHITECTURE.md §5.1). Exact in double up to 2^53 distinct values; result in
/// [0, 1). Base 2 uses a bit reversal. Pure, thread-safe, O(log_b i).
double radicalInverse(int dim, uint64_t index);

/// Base-2 radical inverse by bit reversal: Φ_2(i) = reverse64(i) · 2^-64. O(1).
double radicalInverseBase2(uint64_t index);

/// 64-bit finaliser (SplitMix64 / Stafford variant 13): a bijective avalanche mix.
uint64_t mixBits(uint64_t v);

/// One SplitMix64 output step: mixBits(z + golden-ratio increment). Hashes the eye pass's
/// per-pixel sample rotations.
inline uint64_t splitMix64(uint64_t z) { return mixBits(z + 0x9E3779B97F4A7C15ull); }

/// Base-3 radical inverse accumulated in float (the eye pass's light-sample strata; its rounding
/// is part of the image's bit pattern, so it is not the double radicalInverse rounded). O(log₃ i).
float radicalInverseBase3f(uint32_t index);

/// Hash of up to five 64-bit keys, order-sensitive. Used for rotations and for the random numbers
/// that are not Halton-steered, so they depend only on (seed, set, photon index, bounce, purpose),
/// never on thread order.
uint64_t hashKeys(uint64_t a, uint64_t b, uint64_t c = 0, uint64_t d = 0, uint64_t e = 0);

/// Uniform float in [0, 1) from a 64-bit hash (top 24 bits).
inline float hashToUnit(uint64_t h) {
    return static_cast<float>(h >> 40) * 0x1p-24f;
}

/// A Halton sequence over the first kHaltonMaxDims primes, rotated per interleaving set
/// (Cranley–Patterson: x ↦ (Φ_b(i) + u_d) mod 1, docs/ARCHITECTURE.md §5.1). The offsets u_d are
/// hashed from (seed, stream, dimension), so every set (and every light within a set, via `stream`)
/// draws its own randomised QMC point set while keeping the elementary-box structure that SPT
/// relies on: indices i and i + j·Π b_d^{k_d} still lie in the same (rotated, wrapped) box.
/// Sets are never separated by index strides, which would alias with the bases.
/// Immutable after construction; thread-safe for concurrent `sample` calls.
class Halton {
public:
    /// `seed` global seed, `stream` identifies the point set (e.g. hashKeys(set, light)).
    Halton(uint64_t seed, uint64_t stream);

    /// Rotated Halton coordinate of dimension `dim` (< kHaltonMaxDims) for `index`, in [0, 1).
    float sample(int dim, uint64_t index) const;
    /// Unrotated coordinate Φ_b(index) (for tests and for box bookkeeping).
    static double raw(int dim, uint64_t index) { return radicalInverse(dim, index); }
    /// The Cranley–Patterson offset of dimension `dim`, in [0, 1).
    double rotation(int dim) const { return rotation_[static_cast<size_t>(dim)]; }

private:
    std::array<double, kHaltonMaxDims> rotation_{};
};

}  // namespace rtpm
