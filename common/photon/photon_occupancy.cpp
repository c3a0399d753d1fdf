#include "common/photon/photon_occupancy.h"

#include <algorithm>
#include <cmath>

namespace rtpm {

namespace {
// Cell coordinates are clamped to ±2^40 before the integer conversion: far-away positions share
// the outermost cells (clamping is monotone, so containment is kept), and the conversion of a
// huge float is never undefined.
constexpr float kCellLimit = 1099511627776.0f;
}  // namespace

PhotonOccupancy::PhotonOccupancy(float radius)
    : radius_(radius), margin_(0.0f), invCell_(0.0f) {
    if (std::isfinite(radius) && radius > 0.0f) {
        margin_ = radius * 1.001f;
        invCell_ = 1.0f / (2.5f * radius);
        if (!std::isfinite(invCell_) || !(invCell_ > 0.0f)) invCell_ = 0.0f;
    }
    if (invCell_ > 0.0f) bits_.assign(size_t(1) << (kTableBits - 6), 0);
}

void PhotonOccupancy::clear() { std::fill(bits_.begin(), bits_.end(), 0); }

int64_t PhotonOccupancy::cellOf(float v) const {
    return static_cast<int64_t>(std::floor(std::clamp(v * invCell_, -kCellLimit, kCellLimit)));
}

uint32_t PhotonOccupancy::slot(int64_t x, int64_t y, int64_t z) {
    uint64_t h = uint64_t(x) * 0x9E3779B97F4A7C15ull ^ uint64_t(y) * 0xC2B2AE3D27D4EB4Full ^
                 uint64_t(z) * 0x165667B19E3779F9ull;
    h ^= h >> 29;
    h *= 0xBF58476D1CE4E5B9ull;
    h ^= h >> 32;
    return uint32_t(h & ((uint64_t(1) << kTableBits) - 1));
}

void PhotonOccupancy::insert(std::span<const Photon> photons) {
    if (invCell_ == 0.0f) return;
    for (const Photon& p : photons) {
        if (!finite(p.position)) continue;
        int64_t lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            lo[a] = cellOf(p.position[a] - margin_);
            hi[a] = cellOf(p.position[a] + margin_);
        }
        for (int64_t x = lo[0]; x <= hi[0]; ++x)
            for (int64_t y = lo[1]; y <= hi[1]; ++y)
                for (int64_t z = lo[2]; z <= hi[2]; ++z) {
                    const uint32_t s = slot(x, y, z);
                    bits_[s >> 6] |= uint64_t(1) << (s & 63);
                }
    }
}

bool PhotonOccupancy::mayHaveWithin(Vec3 x) const {
    if (invCell_ == 0.0f || !finite(x)) return true;
    const uint32_t s = slot(cellOf(x.x), cellOf(x.y), cellOf(x.z));
    return (bits_[s >> 6] >> (s & 63)) & 1u;
}

}  // namespace rtpm
