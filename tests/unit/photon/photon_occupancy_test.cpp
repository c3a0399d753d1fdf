// PhotonOccupancy against brute force: "no" must always be right, and it must say "no" often
// enough to matter far from the photons.
#include "common/photon/photon_occupancy.h"

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace rtpm {
namespace {

Photon photonAt(Vec3 p) { return Photon::make(p, Vec3(1.0f), Vec3(0, -1, 0)); }

bool anyWithin(const std::vector<Photon>& photons, Vec3 x, float r) {
    for (const Photon& p : photons) {
        const Vec3 d = p.position - x;
        if (d.x * d.x + d.y * d.y + d.z * d.z < r * r) return true;
    }
    return false;
}

TEST(PhotonOccupancy, NeverDeniesAPhotonWithinTheRadiusAndDeniesFarPoints) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    // A caustic-like layout: photons on a thin ring on the floor of a 4 m scene.
    std::vector<Photon> photons;
    for (int i = 0; i < 4000; ++i) {
        const float a = 3.14159265f * u(rng);
        const float rr = 0.5f + 0.01f * u(rng);
        photons.push_back(photonAt(Vec3(rr * std::cos(a), 0.0f, rr * std::sin(a))));
    }
    const float radius = 0.03f;
    PhotonOccupancy occ(radius);
    occ.insert(std::span<const Photon>(photons).first(2000));
    occ.insert(std::span<const Photon>(photons).subspan(2000));  // batches accumulate
    int denied = 0, far = 0;
    for (int i = 0; i < 20000; ++i) {
        // Queries near the ring (on and just off the radius) and over the whole floor.
        const Vec3 x = i % 2 ? Vec3(2.0f * u(rng), 0.0f, 2.0f * u(rng))
                             : photons[size_t(i) % photons.size()].position +
                                   Vec3(radius * u(rng), 0.01f * u(rng), radius * u(rng));
        const bool truth = anyWithin(photons, x, radius);
        const bool may = occ.mayHaveWithin(x);
        if (truth) {
            ASSERT_TRUE(may) << "photon within r denied at " << x.x << " " << x.y << " " << x.z;
        }
        if (!may) ++denied;
        if (glm::length(Vec3(x.x, 0.0f, x.z)) > 0.7f || glm::length(Vec3(x.x, 0.0f, x.z)) < 0.3f) ++far;
    }
    // Most floor points far from the ring are denied (cells are 2.5 r; the hash table is sparse).
    EXPECT_GT(denied, far * 9 / 10);
}

TEST(PhotonOccupancy, ExactBoundaryCoincidentAndHugeCoordinates) {
    const float radius = 0.1f;
    PhotonOccupancy occ(radius);
    std::vector<Photon> photons(50, photonAt(Vec3(1.0f, 2.0f, 3.0f)));  // coincident
    photons.push_back(photonAt(Vec3(1e30f, -1e30f, 0.0f)));
    photons.push_back(photonAt(Vec3(std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f)));
    occ.insert(photons);
    // Just inside the radius along each axis, both signs.
    for (int a = 0; a < 3; ++a)
        for (float s : {-1.0f, 1.0f}) {
            Vec3 x(1.0f, 2.0f, 3.0f);
            x[a] += s * std::nextafter(radius, 0.0f);
            EXPECT_TRUE(occ.mayHaveWithin(x)) << a << " " << s;
        }
    EXPECT_TRUE(occ.mayHaveWithin(Vec3(1e30f, -1e30f, 0.0f)));
    EXPECT_TRUE(occ.mayHaveWithin(Vec3(std::numeric_limits<float>::infinity(), 0.0f, 0.0f)));
    EXPECT_FALSE(occ.mayHaveWithin(Vec3(1.0f, 2.0f, 4.0f)));
    occ.clear();
    EXPECT_FALSE(occ.mayHaveWithin(Vec3(1.0f, 2.0f, 3.0f)));
}

TEST(PhotonOccupancy, WithoutAUsableRadiusEveryQueryMayHavePhotons) {
    for (float r : {0.0f, -1.0f, std::numeric_limits<float>::quiet_NaN(),
                    std::numeric_limits<float>::infinity()}) {
        PhotonOccupancy occ(r);
        EXPECT_TRUE(occ.mayHaveWithin(Vec3(0.0f)));
        EXPECT_EQ(occ.memoryBytes(), 0u);
    }
}

}  // namespace
}  // namespace rtpm
