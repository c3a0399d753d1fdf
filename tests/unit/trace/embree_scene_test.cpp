// Tests of EmbreeScene: analytic intersections, instancing, normals, offsets at extreme scales, edits.
#include "common/trace/embree_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <glm/gtc/matrix_transform.hpp>

namespace rtpm {
namespace {

constexpr float kPi = 3.14159265358979f;

/// Unit quad [-0.5, 0.5]² in the z = 0 plane, counter-clockwise seen from +z (normal +z).
Mesh makeQuad(float half = 0.5f) {
    Mesh m;
    m.name = "quad";
    m.positions = {{-half, -half, 0}, {half, -half, 0}, {half, half, 0}, {-half, half, 0}};
    m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    m.indices = {0, 1, 2, 0, 2, 3};
    return m;
}

/// UV sphere of `radius` at the origin, outward-facing winding and smooth vertex normals.
Mesh makeSphere(float radius, int stacks, int slices) {
    Mesh m;
    m.name = "sphere";
    for (int i = 0; i <= stacks; ++i) {
        const float theta = kPi * float(i) / float(stacks);
        for (int j = 0; j <= slices; ++j) {
            const float phi = 2.0f * kPi * float(j) / float(slices);
            const Vec3 n(std::sin(theta) * std::cos(phi), std::cos(theta), std::sin(theta) * std::sin(phi));
            m.positions.push_back(radius * n);
            m.normals.push_back(n);
        }
    }
    const int row = slices + 1;
    for (int i = 0; i < stacks; ++i)
        for (int j = 0; j < slices; ++j) {
            const uint32_t a = i * row + j, b = a + 1, c = a + row, d = c + 1;
            m.indices.insert(m.indices.end(), {a, b, c, b, d, c});
        }
    // Orient every triangle outward (pole triangles are degenerate and stay as they are).
    for (size_t t = 0; t < m.indices.size(); t += 3) {
        const Vec3 p0 = m.positions[m.indices[t]], p1 = m.positions[m.indices[t + 1]],
                   p2 = m.positions[m.indices[t + 2]];
        const Vec3 n = glm::cross(p1 - p0, p2 - p0);
        if (glm::dot(n, p0 + p1 + p2) < 0.0f) std::swap(m.indices[t + 1], m.indices[t + 2]);
    }
    return m;
}

Scene sceneWith(Mesh mesh, Mat4 transform = Mat4(1.0f)) {
    Scene s;
    s.materials.push_back(Material{});
    s.meshes.push_back(std::move(mesh));
    s.instances.push_back(Instance{"inst", 0, transform});
    return s;
}

TEST(EmbreeScene, QuadHitDistanceNormalAndUv) {
    Scene scene = sceneWith(makeQuad());
    EmbreeScene es(scene);
    SurfaceHit hit;
    ASSERT_TRUE(es.intersect(Ray{{0.25f, -0.1f, 2.0f}, {0, 0, -1}}, hit));
    EXPECT_NEAR(hit.t, 2.0f, 1e-6f);
    EXPECT_NEAR(hit.position.x, 0.25f, 1e-6f);
    EXPECT_NEAR(hit.position.z, 0.0f, 1e-6f);
    EXPECT_NEAR(hit.geometricNormal.z, 1.0f, 1e-6f);  // counter-clockwise seen from +z
    EXPECT_NEAR(hit.shadingNormal.z, 1.0f, 1e-6f);
    EXPECT_NEAR(hit.uv.x, 0.75f, 1e-5f);
    EXPECT_NEAR(hit.uv.y, 0.4f, 1e-5f);
    // From behind: the geometric normal is not flipped toward the ray.
    ASSERT_TRUE(es.intersect(Ray{{0.0f, 0.0f, -3.0f}, {0, 0, 1}}, hit));
    EXPECT_NEAR(hit.t, 3.0f, 1e-6f);
    EXPECT_NEAR(hit.geometricNormal.z, 1.0f, 1e-6f);
    // Misses outside the quad and beyond tMax.
    EXPECT_FALSE(es.intersect(Ray{{0.6f, 0.0f, 2.0f}, {0, 0, -1}}, hit));
    EXPECT_FALSE(es.intersect(Ray{{0.0f, 0.0f, 2.0f}, {0, 0, -1}, 0.0f, 1.5f}, hit));
    EXPECT_TRUE(es.occluded(Ray{{0.0f, 0.0f, 2.0f}, {0, 0, -1}, 0.0f, 2.5f}));
    EXPECT_FALSE(es.occluded(Ray{{0.0f, 0.0f, 2.0f}, {0, 0, -1}, 0.0f, 1.5f}));
}

TEST(EmbreeScene, TessellatedSphereHitMatchesAnalyticDistanceAndNormal) {
    const float r = 1.0f;
    Scene scene = sceneWith(makeSphere(r, 64, 128));
    EmbreeScene es(scene);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> uni(-0.7f, 0.7f);
    for (int k = 0; k < 200; ++k) {
        const Vec3 o(uni(rng), uni(rng), 5.0f);
        SurfaceHit hit;
        ASSERT_TRUE(es.intersect(Ray{o, {0, 0, -1}}, hit));
        const float tExact = 5.0f - std::sqrt(r * r - o.x * o.x - o.y * o.y);
        // A chord of a 64×128 tessellation lies within r(1 − cos(π/64)) ≈ 1.2e-3 of the sphere.
        EXPECT_NEAR(hit.t, tExact, 4e-3f);
        const Vec3 exactN = glm::normalize(hit.position);
        EXPECT_GT(glm::dot(hit.geometricNormal, exactN), 0.998f);
        EXPECT_GT(glm::dot(hit.shadingNormal, exactN), 0.9999f);
        EXPECT_NEAR(glm::length(hit.geometricNormal), 1.0f, 1e-5f);
    }
}

TEST(EmbreeScene, InstanceTransformAppliedToHitAndNormal) {
    // Quad rotated 90° about x (normal +z → −y), scaled ×2 non-uniformly in x, moved to y = 3.
    Mat4 m = glm::translate(Mat4(1.0f), Vec3(1.0f, 3.0f, 0.0f));
    m = glm::rotate(m, kPi / 2, Vec3(1, 0, 0));
    m = glm::scale(m, Vec3(2.0f, 1.0f, 1.0f));
    Scene scene = sceneWith(makeQuad(), m);
    scene.instances.push_back(Instance{"second", 0, Mat4(1.0f)});
    EmbreeScene es(scene);
    SurfaceHit hit;
    ASSERT_TRUE(es.intersect(Ray{{1.9f, 0.0f, 0.1f}, {0, 1, 0}}, hit));  // x within 1 ± 1
    EXPECT_EQ(hit.instance, 0u);
    EXPECT_NEAR(hit.t, 3.0f, 1e-5f);
    EXPECT_NEAR(hit.geometricNormal.y, -1.0f, 1e-5f);
    EXPECT_NEAR(hit.uv.x, 0.95f, 1e-4f);  // object x = 0.45
    ASSERT_TRUE(es.intersect(Ray{{0.1f, 0.1f, 1.0f}, {0, 0, -1}}, hit));
    EXPECT_EQ(hit.instance, 1u);
    EXPECT_NEAR(hit.geometricNormal.z, 1.0f, 1e-6f);

    // Moving the instance recommits the top level.
    es.setTransform(0, glm::translate(Mat4(1.0f), Vec3(0.0f, 10.0f, 0.0f)) * glm::rotate(Mat4(1.0f), kPi / 2, Vec3(1, 0, 0)));
    ASSERT_TRUE(es.intersect(Ray{{0.0f, 0.0f, 0.1f}, {0, 1, 0}}, hit));
    EXPECT_EQ(hit.instance, 0u);
    EXPECT_NEAR(hit.t, 10.0f, 1e-5f);
}

TEST(EmbreeScene, ManyInstancesOfAMeshStayTwoLevelAndHitLikeTheFlatScene) {
    // Two instances of one quad double its triangles: traced flat. Five would quintuple them:
    // traced in the two-level scene. Both answer the same hits, and follow a moved instance.
    for (int copies : {2, 5}) {
        SCOPED_TRACE(copies);
        Scene scene = sceneWith(makeQuad());
        for (int i = 1; i < copies; ++i)
            scene.instances.push_back(Instance{"copy", 0, glm::translate(Mat4(1.0f), Vec3(2.0f * float(i), 0, 0))});
        EmbreeScene es(scene);
        EXPECT_EQ(es.flattened(), copies <= 2);
        SurfaceHit hit;
        for (int i = 0; i < copies; ++i) {
            ASSERT_TRUE(es.intersect(Ray{{2.0f * float(i) + 0.25f, 0.1f, 1.0f}, {0, 0, -1}}, hit));
            EXPECT_EQ(hit.instance, uint32_t(i));
            EXPECT_NEAR(hit.t, 1.0f, 1e-6f);
            EXPECT_NEAR(hit.uv.x, 0.75f, 1e-5f);
            EXPECT_NEAR(hit.geometricNormal.z, 1.0f, 1e-6f);
            EXPECT_TRUE(es.occluded(Ray{{2.0f * float(i), 0.0f, 1.0f}, {0, 0, -1}, 0.0f, 2.0f}));
        }
        EXPECT_FALSE(es.intersect(Ray{{1.0f, 0.0f, 1.0f}, {0, 0, -1}}, hit));  // between two quads
        es.setTransform(0, glm::translate(Mat4(1.0f), Vec3(0, 0, -3)));
        EXPECT_EQ(es.flattened(), copies <= 2);
        ASSERT_TRUE(es.intersect(Ray{{0.1f, 0.1f, 1.0f}, {0, 0, -1}}, hit));
        EXPECT_EQ(hit.instance, 0u);
        EXPECT_NEAR(hit.t, 4.0f, 1e-5f);
    }
}

TEST(EmbreeScene, NonUniformScaleUsesInverseTransposeForNormals) {
    // A tilted quad squashed along x: the normal must follow the inverse transpose, not M.
    Mesh m = makeQuad();
    for (Vec3& p : m.positions) p.z = 0.5f * p.x;  // plane z = x/2, normal ∝ (−1/2, 0, 1)
    const Mat4 scale = glm::scale(Mat4(1.0f), Vec3(4.0f, 1.0f, 1.0f));  // world plane z = x/8
    Scene scene = sceneWith(m, scale);
    EmbreeScene es(scene);
    SurfaceHit hit;
    ASSERT_TRUE(es.intersect(Ray{{0.0f, 0.0f, 5.0f}, {0, 0, -1}}, hit));
    const Vec3 expected = glm::normalize(Vec3(-1.0f / 8.0f, 0.0f, 1.0f));
    EXPECT_GT(glm::dot(hit.geometricNormal, expected), 1.0f - 1e-6f);
}

TEST(EmbreeScene, ShadingNormalPutInGeometricHemisphere) {
    Mesh m = makeQuad();
    m.normals.assign(4, Vec3(0, 0, -1));  // vertex normals disagree with the winding
    Scene scene = sceneWith(m);
    EmbreeScene es(scene);
    SurfaceHit hit;
    ASSERT_TRUE(es.intersect(Ray{{0.0f, 0.1f, 1.0f}, {0, 0, -1}}, hit));
    EXPECT_GT(glm::dot(hit.shadingNormal, hit.geometricNormal), 0.0f);
}

TEST(EmbreeScene, DegenerateTrianglesGiveNoNaN) {
    Mesh m = makeQuad();
    // Zero-area triangles: repeated vertex and collinear vertices, plus NaN-free vertex normals of
    // zero length.
    m.positions.push_back({0.0f, 0.0f, 0.0f});
    m.positions.push_back({0.5f, 0.0f, 0.0f});
    m.positions.push_back({1.0f, 0.0f, 0.0f});
    m.indices.insert(m.indices.end(), {4, 4, 5, 4, 5, 6});
    m.normals.assign(m.positions.size(), Vec3(0.0f));
    Scene scene = sceneWith(m);
    scene.materials[0].emission = Vec3(1.0f);
    EmbreeScene es(scene);
    EXPECT_EQ(es.emissiveTriangles().size(), 2u);  // degenerate emitters are dropped
    for (const auto& e : es.emissiveTriangles()) {
        EXPECT_TRUE(std::isfinite(e.normal.x) && std::isfinite(e.normal.z));
        EXPECT_NEAR(e.area, 0.5f, 1e-6f);
    }
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> uni(-1.0f, 1.0f);
    for (int k = 0; k < 2000; ++k) {
        const Vec3 o(uni(rng), uni(rng), 1.0f);
        const Vec3 d = glm::normalize(Vec3(uni(rng) * 0.2f, uni(rng) * 0.2f, -1.0f));
        SurfaceHit hit;
        if (!es.intersect(Ray{o, d}, hit)) continue;
        ASSERT_TRUE(std::isfinite(hit.geometricNormal.x + hit.geometricNormal.y + hit.geometricNormal.z));
        ASSERT_TRUE(std::isfinite(hit.shadingNormal.x + hit.shadingNormal.y + hit.shadingNormal.z));
        ASSERT_NEAR(glm::length(hit.geometricNormal), 1.0f, 1e-4f);
        ASSERT_NEAR(glm::length(hit.shadingNormal), 1.0f, 1e-4f);
    }
}

/// Rays that hit a convex sphere from outside and leave it again (reflected, or from the inside
/// after "refraction" toward the centre) must not re-hit the triangle they started on.
void checkNoSelfIntersection(float radius, Vec3 centre) {
    Scene scene = sceneWith(makeSphere(radius, 24, 48), glm::translate(Mat4(1.0f), centre));
    EmbreeScene es(scene);
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> uni(-1.0f, 1.0f);
    int hits = 0;
    for (int k = 0; k < 4000; ++k) {
        // Origins on a shell at 3r, aimed near the centre; many rays arrive at grazing angles.
        Vec3 dirToCentre = glm::normalize(Vec3(uni(rng), uni(rng), uni(rng)) + Vec3(1e-3f));
        const Vec3 origin = centre - 3.0f * radius * dirToCentre;
        const Vec3 aim = centre + 0.999f * radius * Vec3(uni(rng), uni(rng), uni(rng));
        const Vec3 d = glm::normalize(aim - origin);
        SurfaceHit hit;
        if (!es.intersect(Ray{origin, d}, hit)) continue;
        ++hits;
        // Outgoing reflected ray on the outside.
        const Vec3 n = hit.geometricNormal;
        const Vec3 r = d - 2.0f * glm::dot(d, n) * n;
        const Vec3 o1 = es.offsetOrigin(hit.position, n, r);
        SurfaceHit again;
        if (es.intersect(Ray{o1, r}, again)) {
            // A reflected ray can legitimately hit a neighbouring facet only when the tessellation
            // is concave there, which a convex sphere never is.
            ADD_FAILURE() << "reflected ray re-hit triangle " << again.triangle << " (from "
                          << hit.triangle << ") at t = " << again.t << ", scale " << radius;
            return;
        }
        // Ray continuing inside: the next hit must be a different triangle on the far side.
        const Vec3 o2 = es.offsetOrigin(hit.position, n, d);
        ASSERT_TRUE(es.intersect(Ray{o2, d}, again)) << "scale " << radius;
        EXPECT_NE(again.triangle, hit.triangle) << "scale " << radius;
        // A shadow ray back to the origin must be unoccluded.
        const Vec3 o3 = es.offsetOrigin(hit.position, n, origin - hit.position);
        EXPECT_FALSE(es.occluded(Ray{o3, origin - o3, 0.0f, 0.999f})) << "scale " << radius;
    }
    EXPECT_GT(hits, 1000);
}

TEST(EmbreeScene, OffsetAvoidsSelfIntersectionAtMillimetreScale) {
    checkNoSelfIntersection(1e-3f, Vec3(0.0f));
    checkNoSelfIntersection(1e-3f, Vec3(2e-3f, -1e-3f, 5e-4f));
}

TEST(EmbreeScene, OffsetAvoidsSelfIntersectionAtHundredKilometreScale) {
    checkNoSelfIntersection(1e5f, Vec3(0.0f));
    checkNoSelfIntersection(1e5f, Vec3(2e5f, -1e5f, 3e4f));
}

TEST(EmbreeScene, OffsetScalesWithSceneAndPosition) {
    Scene small = sceneWith(makeQuad(0.5e-3f));
    Scene large = sceneWith(makeQuad(0.5e5f));
    EmbreeScene a(small), b(large);
    EXPECT_LT(a.epsilon(), 1e-8f);
    EXPECT_GT(b.epsilon(), 1e-2f);
    const Vec3 n(0, 0, 1);
    const Vec3 pa = a.offsetOrigin(Vec3(0.0f), n, Vec3(0, 0, -1));
    EXPECT_LT(pa.z, 0.0f);  // toward the side of `towards`
    EXPECT_GT(pa.z, -1e-7f);
    // A point far from the origin gets an offset that exceeds its float spacing.
    const Vec3 far(1e5f, 0.0f, 0.0f);
    const Vec3 pb = a.offsetOrigin(far, n, n);
    EXPECT_GT(pb.z, std::nextafter(1e5f, 2e5f) - 1e5f);
}

TEST(EmbreeScene, EmissiveTrianglesInWorldSpace) {
    Mat4 m = glm::translate(Mat4(1.0f), Vec3(0.0f, 2.0f, 0.0f)) *
             glm::rotate(Mat4(1.0f), kPi / 2, Vec3(1, 0, 0)) * glm::scale(Mat4(1.0f), Vec3(2.0f));
    Scene scene = sceneWith(makeQuad(), m);  // 2×2 quad at y = 2 facing −y
    scene.materials[0].emission = Vec3(3.0f, 2.0f, 1.0f);
    EmbreeScene es(scene);
    ASSERT_EQ(es.emissiveTriangles().size(), 2u);
    float area = 0.0f;
    for (const auto& e : es.emissiveTriangles()) {
        area += e.area;
        EXPECT_NEAR(e.normal.y, -1.0f, 1e-6f);
        EXPECT_NEAR(e.p0.y, 2.0f, 1e-6f);
        EXPECT_EQ(e.radiance, Vec3(3.0f, 2.0f, 1.0f));
    }
    EXPECT_NEAR(area, 4.0f, 1e-5f);
    es.setTransform(0, glm::translate(Mat4(1.0f), Vec3(0, 0, 7)));
    for (const auto& e : es.emissiveTriangles()) EXPECT_NEAR(e.p1.z, 7.0f, 1e-6f);
}

TEST(EmbreeScene, SetMeshRebuildsGeometry) {
    Scene scene = sceneWith(makeQuad());
    scene.instances.push_back(Instance{"moved", 0, glm::translate(Mat4(1.0f), Vec3(5, 0, 0))});
    EmbreeScene es(scene);
    SurfaceHit hit;
    EXPECT_FALSE(es.intersect(Ray{{1.5f, 0.0f, 1.0f}, {0, 0, -1}}, hit));
    es.setMesh(0, makeQuad(2.0f));
    ASSERT_TRUE(es.intersect(Ray{{1.5f, 0.0f, 1.0f}, {0, 0, -1}}, hit));
    EXPECT_EQ(hit.instance, 0u);
    ASSERT_TRUE(es.intersect(Ray{{6.5f, 0.0f, 1.0f}, {0, 0, -1}}, hit));  // the shared mesh changed too
    EXPECT_EQ(hit.instance, 1u);
    EXPECT_NEAR(es.bounds().hi.x, 7.0f, 1e-6f);
}

TEST(EmbreeScene, BadIndicesRaiseSceneError) {
    Mesh m = makeQuad();
    m.indices.push_back(0);
    m.indices.push_back(1);
    m.indices.push_back(99);
    Scene scene = sceneWith(m);
    EXPECT_THROW(EmbreeScene es(scene), SceneError);
    Scene badInstance = sceneWith(makeQuad());
    badInstance.instances[0].mesh = 4;
    EXPECT_THROW(EmbreeScene es(badInstance), SceneError);
    Scene singular = sceneWith(makeQuad(), Mat4(0.0f));
    EXPECT_THROW(EmbreeScene es(singular), SceneError);
}

TEST(EmbreeScene, EmptySceneMissesEverything) {
    Scene scene;
    EmbreeScene es(scene);
    SurfaceHit hit;
    EXPECT_FALSE(es.intersect(Ray{{0, 0, 0}, {0, 0, 1}}, hit));
    EXPECT_FALSE(es.occluded(Ray{{0, 0, 0}, {0, 0, 1}}));
    EXPECT_TRUE(es.emissiveTriangles().empty());
}

TEST(EmbreeScene, PacketOcclusionMatchesSingleRaysForEveryPacketSize) {
    Scene scene = sceneWith(makeSphere(1.0f, 24, 48));
    EmbreeScene es(scene);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-3.0f, 3.0f);
    int blocked = 0, free = 0;
    for (int trial = 0; trial < 50; ++trial) {
        for (int count = 0; count <= 8; ++count) {
            Ray rays[8];
            uint32_t expected = 0;
            for (int i = 0; i < count; ++i) {
                // Segments between random points: some cross the sphere, some stop short of it.
                const Vec3 a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng));
                rays[i] = Ray{a, b - a, 0.0f, 1.0f};
                if (es.occluded(rays[i])) expected |= 1u << i;
                (expected & (1u << i)) ? ++blocked : ++free;
            }
            ASSERT_EQ(es.occluded8(rays, count), expected) << "trial " << trial << " count " << count;
        }
    }
    EXPECT_GT(blocked, 100);
    EXPECT_GT(free, 100);
}

}  // namespace
}  // namespace rtpm
