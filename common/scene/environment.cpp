// Environment: equirectangular lookup and the piecewise-constant importance sampling of the map.
#include "common/scene/environment.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "common/scene/scene.h"

namespace rtpm {

namespace {

constexpr double kPiD = std::numbers::pi;

float channelSum(Vec3 v) { return v.x + v.y + v.z; }

// Index of the slot of `cdf` (ascending, last 1) that u falls in, skipping empty slots, and the
// position of u within it, in [0, 1).
size_t invertCdf(const double* cdf, size_t n, double u, double& fraction) {
    const size_t i = std::min<size_t>(size_t(std::upper_bound(cdf, cdf + n, u) - cdf), n - 1);
    const double lo = i == 0 ? 0.0 : cdf[i - 1];
    const double width = cdf[i] - lo;
    fraction = width > 0.0 ? std::clamp((u - lo) / width, 0.0, 1.0) : 0.5;
    return i;
}

}  // namespace

Environment Environment::uniform(Vec3 radiance) {
    Environment e;
    e.uniform_ = radiance;
    e.integral_ = 4.0f * kPi * radiance;
    return e;
}

Environment Environment::fromMap(const Texture& map) {
    Environment e;
    e.width_ = map.width;
    e.height_ = map.height;
    e.rgb_ = map.rgb;
    const size_t w = size_t(map.width), h = size_t(map.height);
    e.rowCdf_.assign(h, 0.0);
    e.colCdf_.assign(w * h, 0.0);
    glm::dvec3 integral(0.0);
    double total = 0.0;
    for (size_t j = 0; j < h; ++j) {
        const double omega = 2.0 * kPiD / double(w) *
                             (std::cos(kPiD * double(j) / double(h)) - std::cos(kPiD * double(j + 1) / double(h)));
        double row = 0.0;
        for (size_t i = 0; i < w; ++i) {
            const float* t = &e.rgb_[(j * w + i) * 3];
            integral += glm::dvec3(t[0], t[1], t[2]) * omega;
            row += double(channelSum(Vec3(t[0], t[1], t[2]))) * omega;
            e.colCdf_[j * w + i] = row;
        }
        for (size_t i = 0; i < w; ++i) e.colCdf_[j * w + i] = row > 0.0 ? e.colCdf_[j * w + i] / row : 1.0;
        e.colCdf_[j * w + w - 1] = 1.0;
        total += row;
        e.rowCdf_[j] = total;
    }
    for (double& c : e.rowCdf_) c = total > 0.0 ? c / total : 1.0;
    e.rowCdf_.back() = 1.0;
    e.weightSum_ = total;
    e.integral_ = Vec3(integral);
    return e;
}

Vec2 Environment::uvOf(Vec3 d) {
    const float u = std::atan2(d.z, d.x) / (2.0f * kPi) + 0.5f;
    const float v = std::acos(std::clamp(d.y, -1.0f, 1.0f)) / kPi;
    return Vec2(u, v);
}

Vec3 Environment::directionOf(Vec2 uv) {
    const float phi = 2.0f * kPi * (uv.x - 0.5f);
    const float theta = kPi * uv.y;
    const float s = std::sin(theta);
    return Vec3(s * std::cos(phi), std::cos(theta), s * std::sin(phi));
}

size_t Environment::texelOf(Vec3 d) const {
    const Vec2 uv = uvOf(d);
    const int i = std::clamp(int(uv.x * float(width_)), 0, width_ - 1);
    const int j = std::clamp(int(uv.y * float(height_)), 0, height_ - 1);
    return size_t(j) * size_t(width_) + size_t(i);
}

Vec3 Environment::radiance(Vec3 d) const {
    if (!hasMap()) return uniform_;
    const float* t = &rgb_[texelOf(d) * 3];
    return Vec3(t[0], t[1], t[2]);
}

float Environment::pdf(Vec3 d) const {
    if (empty()) return 0.0f;
    if (!hasMap()) return float(1.0 / (4.0 * kPiD));
    const size_t t = texelOf(d);
    const size_t w = size_t(width_), j = t / w, i = t % w;
    const double pRow = rowCdf_[j] - (j > 0 ? rowCdf_[j - 1] : 0.0);
    const double pCol = colCdf_[t] - (i > 0 ? colCdf_[t - 1] : 0.0);
    const double omega = 2.0 * kPiD / double(w) *
                         (std::cos(kPiD * double(j) / double(height_)) - std::cos(kPiD * double(j + 1) / double(height_)));
    return omega > 0.0 ? float(pRow * pCol / omega) : 0.0f;
}

EnvironmentSample Environment::sample(Vec2 u) const {
    EnvironmentSample s;
    if (empty()) return s;
    if (!hasMap()) {
        const float z = 1.0f - 2.0f * u.x;
        const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
        const float phi = 2.0f * kPi * u.y;
        s.direction = Vec3(r * std::cos(phi), z, r * std::sin(phi));
        s.radiance = uniform_;
        s.pdf = float(1.0 / (4.0 * kPiD));
        return s;
    }
    const size_t w = size_t(width_), h = size_t(height_);
    double fr = 0.0, fc = 0.0;
    const size_t j = invertCdf(rowCdf_.data(), h, double(u.x), fr);
    const size_t i = invertCdf(colCdf_.data() + j * w, w, double(u.y), fc);
    const double c0 = std::cos(kPiD * double(j) / double(h)), c1 = std::cos(kPiD * double(j + 1) / double(h));
    const double cosTheta = c0 - fr * (c0 - c1);
    const double sinTheta = std::sqrt(std::max(0.0, 1.0 - cosTheta * cosTheta));
    const double phi = 2.0 * kPiD * ((double(i) + fc) / double(w) - 0.5);
    s.direction = glm::normalize(Vec3(float(sinTheta * std::cos(phi)), float(cosTheta), float(sinTheta * std::sin(phi))));
    const size_t t = j * w + i;
    s.radiance = Vec3(rgb_[t * 3], rgb_[t * 3 + 1], rgb_[t * 3 + 2]);
    const double pRow = rowCdf_[j] - (j > 0 ? rowCdf_[j - 1] : 0.0);
    const double pCol = colCdf_[t] - (i > 0 ? colCdf_[t - 1] : 0.0);
    const double omega = 2.0 * kPiD / double(w) * (c0 - c1);
    s.pdf = omega > 0.0 ? float(pRow * pCol / omega) : 0.0f;
    return s;
}

void validateEnvironmentMap(const Texture& map, const std::string& file) {
    const std::string size = std::to_string(map.width) + "x" + std::to_string(map.height);
    if (map.width <= 0 || map.height <= 0 || map.width != 2 * map.height)
        throw SceneError(file, "environment",
                         "an environment map must be equirectangular, twice as wide as high (e.g. "
                         "2048x1024); this one is " + size);
    if (uint64_t(map.width) * uint64_t(map.height) > kMaxEnvironmentTexels)
        throw SceneError(file, "environment",
                         "map of " + size + " texels is larger than 4096x2048; downsample it (e.g. "
                         "oiiotool IN --resize 4096x2048 -o OUT)");
    if (map.rgb.size() != size_t(map.width) * size_t(map.height) * 3)
        throw SceneError(file, "environment", "map data does not match its size " + size);
    for (size_t k = 0; k < map.rgb.size(); ++k) {
        const float v = map.rgb[k];
        if (std::isfinite(v) && v >= 0.0f && v <= kMaxRadiantValue) continue;
        const size_t texel = k / 3;
        throw SceneError(file, "environment",
                         std::string("texel at column ") + std::to_string(texel % size_t(map.width)) +
                             ", row " + std::to_string(texel / size_t(map.width)) + " is " +
                             (std::isnan(v) ? "NaN" : std::isinf(v) ? "infinite" : v < 0.0f ? "negative" : "above 1e26") +
                             ": radiance must be finite, non-negative and at most 1e26");
    }
}

}  // namespace rtpm
