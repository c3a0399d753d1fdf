// The eye pass: per pixel, a primary ray, deterministic splitting along specular chains, and at
// each diffuse end point direct light by shadow rays plus the caustic estimate (paper §4.2).
//
// Choices the paper leaves open (docs/ARCHITECTURE.md §11):
// * Dielectrics split the path deterministically: both the reflected (×F) and the refracted
//   (×(1−F)) branch are traced with a small explicit stack, branches whose throughput falls below
//   kMinThroughput are dropped. One pixel is then noise-free through glass and the image does not
//   depend on any random choice. Refraction does not scale radiance by (ηt/ηi)²: an eye path that
//   enters a dielectric leaves it again through as many interfaces, so the factors cancel.
// * A moving camera's frames sample the splits instead (renderSet's sampleSeed): both branches
//   while each carries at least kSplitThroughput of the pixel (the first surfaces a viewer
//   sees), below that one branch chosen by its Fresnel share, weighted by the inverse of its
//   probability; the branches that exist and their pruning are the deterministic tree's, so the
//   mean over seeds is the deterministic image. On GLASS (640×480) a frame then casts about a
//   tenth of the secondary rays (tests/bench/RESULTS.md).
// * Beer–Lambert: a segment that ends on the back face of a dielectric (dot(dir, Ng) > 0) ran
//   inside that dielectric, and is attenuated by its absorption over the segment length. Nested
//   media are modelled as separate closed surfaces (liquid inside glass), each handled this way.
// * Shadow rays are blocked by every surface, dielectrics included: light focused or refracted by
//   glass is caustic light and comes from the photon map, never from the direct term.
// * Sample rotations are hashed from the pixel's image coordinates and the path vertex number,
//   never from thread or set order: the image is identical for any thread count or set split.
// * Mirrors reflect with baseColor (no texture); diffuse albedo is baseColor × texture(uv).
// * A partly transmissive dielectric (transmission t < 1) is split deterministically like a
//   Fresnel split: the Lambertian share (1 − t) is shaded at the hit (direct light and caustic
//   estimate, albedo baseColor × texture), the dielectric share t continues through the Fresnel
//   split below. The photon tracer makes the same choice stochastically (photon_tracer.cpp).
// * Unlit materials (KHR_materials_unlit) return baseColor × texture and end the path.
// * The light at a diffuse end point (shadow rays, area-light and world-light samples) is in
//   eye_light.cpp, the glossy vertices' sampled trees in eye_glossy.cpp.
#include "common/trace/eye_pass.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

#include "common/core/check.h"
#include "common/core/halton.h"
#include "common/core/math.h"
#include "common/core/sampling.h"
#include "common/trace/eye_shading.h"
#include "common/trace/optics.h"

namespace rtpm {

using namespace detail;

namespace {

/// Sampled splits (renderSet's sampleSeed): a dielectric split is traced both ways while each
/// branch carries at least this share of the pixel, else one branch is chosen at random.
constexpr float kSplitThroughput = 0.25f;
constexpr int kMaxTrianglesSampledEach = 16;
constexpr int kStackSize = 64;

Context makeContext(const EmbreeScene& scene, const EyeSettings& settings,
                    const CausticEstimator* caustics, int set) {
    Context ctx{scene, scene.scene(), settings, caustics, set, 0, std::max(1, settings.areaLightSamples),
                true, 0, {}};
    const auto& tris = scene.emissiveTriangles();
    ctx.sampleEach = int(tris.size()) <= kMaxTrianglesSampledEach;
    ctx.maxAreaSamples = ctx.areaSamples * (ctx.sampleEach ? int(tris.size()) : kMaxTrianglesSampledEach);
    if (!ctx.scene.environment.empty()) ctx.environment = &ctx.scene.environment;
    if (!tris.empty()) {
        Bounds b;
        for (const EmissiveTriangle& e : tris) {
            b.extend(e.p0);
            b.extend(e.p1);
            b.extend(e.p2);
        }
        ctx.emitterCentre = 0.5f * (b.lo + b.hi);
        const Vec3 half = 0.5f * (b.hi - b.lo);
        ctx.emitterRadius2 = glm::dot(half, half);
        if (!std::isfinite(ctx.emitterRadius2)) ctx.emitterRadius2 = std::numeric_limits<float>::infinity();
        ctx.cdf.resize(tris.size());
        double acc = 0.0;
        for (size_t i = 0; i < tris.size(); ++i) {
            const Vec3 rad = tris[i].radiance;
            const double power = double(tris[i].area) * double(std::max(0.0f, rad.x + rad.y + rad.z));
            acc += std::isfinite(power) ? power : 0.0;
            ctx.cdf[i] = float(acc);
        }
        for (float& c : ctx.cdf) c = acc > 0.0 ? float(c / acc) : 1.0f;
        ctx.cdf.back() = 1.0f;
    }
    return ctx;
}

/// A caustic lookup a pixel of the packet asks for: shadePixel queues them, renderSet answers a
/// packet's lookups as one group (CausticEstimator::radianceGroup) and adds throughput × radiance
/// to the pixel's caustic in queue order.
struct CausticRequest {
    SurfaceHit hit;
    Vec3 normal;
    Vec3 albedo;
    Vec3 throughput;
    int lane;
};

/// One pixel's shading: what shadePixel's steps share (its result, where its records and caustic
/// lookups go, and the counters its hashed numbers are keyed by).
struct PixelShading {
    const Context& ctx;
    uint64_t pixelKey;  // (y, x): the key of the pixel's hashed numbers
    Counters& count;
    std::vector<CausticRequest>& requests;
    int lane;
    std::vector<EyeHit>* hits;
    uint32_t pixel;
    PixelRadiance result;
    uint32_t diffuseVertex = 0;
    uint32_t glossyVertex = 0;
    uint32_t split = 0;  // dielectric splits so far: the key of a sampled split's random number
};

/// Lambertian end point (or the Lambertian share of a partly transmissive dielectric, or a plastic's
/// base with its `coat`, weighted by `throughput`): direct light by shadow rays plus the caustic
/// estimate.
void shadeDiffuse(PixelShading& px, const SurfaceHit& hit, const Material& mat, Vec3 ns, Vec3 ng,
                  Vec3 throughput, const PlasticBsdf* coat = nullptr) {
    const Context& ctx = px.ctx;
    const Vec3 albedo = baseColorAt(mat, ctx.scene.textures, hit.uv);
    const uint64_t h = splitMix64(px.pixelKey ^ splitMix64(px.diffuseVertex++));
    const std::array<float, 3> rot{hashToUnit(h), hashToUnit(splitMix64(h + 1)), hashToUnit(splitMix64(h + 2))};
    if (px.hits) {  // progressive: keep the record; the caustic comes from the passes
        EyeHit& e = px.hits->emplace_back();
        e.hit = hit;
        e.normal = ns;
        e.geometricNormal = ng;
        e.albedo = albedo;
        e.throughput = throughput;
        e.rotation = rot;
        e.pixel = px.pixel;
        if (!ctx.recordLights) return;  // relightSet lights it
        px.result.direct += throughput * punctualLight(ctx, hit, ns, ng, albedo, px.count, coat);
        e.areaDirect = areaLight(ctx, hit, ns, ng, albedo, rot, px.count, Vec3(0.0f), coat);
        if (!finite(e.areaDirect)) {
            e.areaDirect = Vec3(0.0f);
            ++px.count.nonFinite;
        }
        return;
    }
    px.result.direct += throughput * directLight(ctx, hit, ns, ng, albedo, rot, px.count, coat);
    if (ctx.caustics) px.requests.push_back(CausticRequest{hit, ns, albedo, throughput, px.lane});
}

/// A glossy vertex ends the split path; what arrives there is sampled (eye_glossy.cpp) and weighted
/// by `path`'s throughput, or recorded with its end points (record mode).
void shadeGlossy(PixelShading& px, const SurfaceHit& hit, Vec3 dir, Vec3 ns, Vec3 ng, const PathState& path) {
    const Context& ctx = px.ctx;
    const uint64_t h = splitMix64(px.pixelKey ^ splitMix64(0x676c6f7373ull + px.glossyVertex++));
    const std::array<float, 3> rot{hashToUnit(h), hashToUnit(splitMix64(h + 1)), hashToUnit(splitMix64(h + 2))};
    if (px.hits) {
        // The end points' caustic hits first, then the glossy vertex (its direct light
        // refined per pass): a pixel's first hit stays a diffuse one where it has one.
        EyeHit vertex;
        vertex.hit = hit;
        vertex.normal = ns;
        vertex.geometricNormal = ng;
        vertex.throughput = path.throughput;
        vertex.rotation = rot;
        vertex.pixel = px.pixel;
        vertex.wo = -glm::normalize(dir);
        vertex.set = uint16_t(ctx.set);
        vertex.depth = uint16_t(path.depth);
        vertex.kind = EyeHit::Kind::Glossy;
        if (!ctx.recordLights) {  // relightSet traces its trees
            px.hits->push_back(vertex);
            return;
        }
        vertex.areaDirect = glossyTree(ctx, uint32_t(ctx.set), hit, dir, ng, ns, path.depth, rot, 0,
                                       ctx.settings.glossySamples, GlossyCaustic::Record, px.count, px.hits,
                                       &vertex).direct;
        if (!finite(vertex.areaDirect)) {
            vertex.areaDirect = Vec3(0.0f);
            ++px.count.nonFinite;
        }
        px.hits->push_back(vertex);
    } else {
        const GlossyRadiance g = glossyTree(ctx, uint32_t(ctx.set), hit, dir, ng, ns, path.depth, rot, 0,
                                            ctx.settings.glossySamples, GlossyCaustic::Lookup, px.count);
        px.result.direct += path.throughput * path.weight * g.direct;
        px.result.caustic += path.throughput * path.weight * g.caustic;
    }
}

/// Dielectric at `hit`: the side is decided by the geometric normal, the angles by the shading one.
/// Both branches are kept (the reflected one pushed on `stack`) or, with sampled splits, one is
/// chosen. Returns true with `path` set to the branch to follow on, false when none is left.
bool splitDielectric(PixelShading& px, const SurfaceHit& hit, const Material& mat, Vec3 dir, Vec3 ns,
                     Vec3 ng, PathState& path, PathState* stack, int& top) {
    const Context& ctx = px.ctx;
    const EmbreeScene& es = ctx.es;
    const DielectricInterface side = dielectricInterface(dir, hit.geometricNormal, mat.ior);
    const Vec3 nFace = ns;  // faces the incident side
    const float cosI = std::clamp(-glm::dot(dir, nFace), 0.0f, 1.0f);
    Vec3 t;
    const bool canRefract = refract(dir, nFace, side.etaI / side.etaT, t) &&
                            glm::dot(t, ng) < 0.0f;
    const float fr = canRefract ? fresnelDielectric(cosI, side.etaI, side.etaT) : 1.0f;
    Vec3 r = glm::normalize(reflect(dir, nFace));
    if (glm::dot(r, ng) <= 0.0f) r = glm::normalize(reflect(dir, ng));
    const Vec3 reflThroughput = path.throughput * fr;
    const Vec3 transThroughput = path.throughput * (1.0f - fr);
    const int depth = path.depth + 1;
    const bool keepRefl = maxComponent(reflThroughput) >= kMinThroughput;
    const bool keepTrans = canRefract && maxComponent(transThroughput) >= kMinThroughput;
    if (keepRefl && keepTrans) {
        // Sampled splits (a moving camera's frames): a split whose weaker branch would
        // carry less than kSplitThroughput of the pixel traces one branch, reflection
        // with probability F, weighted by 1/F or 1/(1 − F). The branches kept and their
        // throughputs are the deterministic tree's, so the expectation is its image.
        if (ctx.sampleSeed != 0 &&
            std::min(maxComponent(reflThroughput), maxComponent(transThroughput)) * path.weight <
                kSplitThroughput) {
            ++px.count.sampledSplits;
            const float u = hashToUnit(hashKeys(ctx.sampleSeed, px.pixelKey, px.split++));
            path = u < fr ? PathState{Ray{es.offsetOrigin(hit.position, ng, r), r}, reflThroughput, depth,
                                      path.weight / fr}
                          : PathState{Ray{es.offsetOrigin(hit.position, ng, t), t}, transThroughput, depth,
                                      path.weight / (1.0f - fr)};
            return true;
        }
        if (top < kStackSize)
            stack[top++] = PathState{Ray{es.offsetOrigin(hit.position, ng, r), r}, reflThroughput, depth,
                                     path.weight};
        else
            ++px.count.stackOverflow;
    }
    if (keepTrans) {
        path = PathState{Ray{es.offsetOrigin(hit.position, ng, t), t}, transThroughput, depth, path.weight};
        return true;
    }
    if (keepRefl) {
        path = PathState{Ray{es.offsetOrigin(hit.position, ng, r), r}, reflThroughput, depth, path.weight};
        return true;
    }
    return false;
}

/// Answers a packet's queued caustic lookups as one group (CausticEstimator::radianceGroup, with the
/// row's `hint`) and adds throughput × radiance to their pixels (`packet`: the packet's pixels, by
/// lane); `queries` and `answers` are scratch. A non-finite caustic becomes 0 and is counted.
void answerCaustics(const Context& ctx, const std::vector<CausticRequest>& requests, std::vector<CausticQuery>& queries,
                    std::vector<Vec3>& answers, GatherHint& hint, std::span<PixelRadiance> packet, Counters& count) {
    if (!requests.empty()) {
        queries.resize(requests.size());
        answers.resize(requests.size());
        for (size_t i = 0; i < requests.size(); ++i)
            queries[i] = CausticQuery{&requests[i].hit, requests[i].normal, requests[i].albedo};
        ctx.caustics->radianceGroup(ctx.es, uint32_t(ctx.set), queries, answers, &hint);
        for (size_t i = 0; i < requests.size(); ++i)
            packet[size_t(requests[i].lane)].caustic += requests[i].throughput * answers[i];
    }
    for (PixelRadiance& p : packet)
        if (!finite(p.caustic)) {
            p.caustic = Vec3(0.0f);
            ++count.nonFinite;
        }
}

/// `stack` is kStackSize entries of scratch owned by the calling task: constructing the split
/// stack per pixel (64 rays with their default values) cost more than a typical pixel's shading.
/// With `hits` (record mode) the diffuse end points are appended to it (pixel index `pixel`),
/// the pixel's direct value leaves out their area-light term (EyeHit::areaDirect holds it) and
/// no caustic is looked up. Otherwise, with an estimator, each diffuse end point queues its
/// caustic lookup in `requests` (tagged `lane`); the returned caustic is 0 until renderSet adds
/// the answers.
/// The primary ray is traced by the caller (renderSet: 8 neighbouring pixels per Embree packet):
/// `firstHit` is what it hit, null for a miss.
PixelRadiance shadePixel(const Context& ctx, int x, int y, const Ray& primaryRay,
                         const SurfaceHit* firstHit, PathState* stack, Counters& count,
                         std::vector<CausticRequest>& requests, int lane,
                         std::vector<EyeHit>* hits = nullptr, uint32_t pixel = 0) {
    const EmbreeScene& es = ctx.es;
    const Scene& scene = ctx.scene;
    PixelShading px{ctx, (uint64_t(uint32_t(y)) << 32) | uint32_t(x), count, requests, lane, hits, pixel, {}};
    PixelRadiance& result = px.result;
    int top = 0;
    stack[top++] = PathState{primaryRay, Vec3(1.0f), 0};
    bool primary = true;

    while (top > 0) {
        PathState path = stack[--top];
        for (;;) {  // follow one branch; dielectric splits push the reflected branch
            SurfaceHit hit;
            if (primary) {
                ++count.primary;
                primary = false;
                if (!firstHit) {
                    if (ctx.environment) result.direct += ctx.environment->radiance(glm::normalize(path.ray.dir));
                    break;
                }
                hit = *firstHit;
            } else {
                ++count.secondary;
                if (!es.intersect(path.ray, hit)) {
                    if (ctx.environment)
                        result.direct += path.throughput * path.weight *
                                         ctx.environment->radiance(glm::normalize(path.ray.dir));
                    break;
                }
            }
            const Material& mat = scene.materials[hit.material];
            const Vec3 dir = path.ray.dir;
            const float cosGeo = glm::dot(dir, hit.geometricNormal);

            // A clear medium (σ = 0) attenuates by exp(−0) = 1 exactly: skip the three exp calls.
            if (mat.type == MaterialType::Dielectric && cosGeo > 0.0f && mat.absorption != Vec3(0.0f))
                path.throughput *= beerLambert(mat.absorption, hit.t * glm::length(dir));
            if (mat.isEmissive() && cosGeo < 0.0f)
                result.direct += path.throughput * path.weight * (mat.emissiveTexture >= 0
                                                        ? emissionAt(mat, scene.textures, hit.uv)
                                                        : mat.emission);

            // Normals facing the viewer.
            const Vec3 ng = cosGeo > 0.0f ? -hit.geometricNormal : hit.geometricNormal;
            const Vec3 ns = cosGeo > 0.0f ? -hit.shadingNormal : hit.shadingNormal;

            // Lambertian end point: direct light by shadow rays plus the caustic estimate.
            if (mat.type == MaterialType::Diffuse) {
                if (mat.unlit)
                    result.direct += path.throughput * path.weight * baseColorAt(mat, scene.textures, hit.uv);
                else
                    shadeDiffuse(px, hit, mat, ns, ng, path.throughput * path.weight);
                break;
            }
            if (mat.type == MaterialType::Plastic) {
                // The base is a diffuse end point weighted by its view share; the coat goes on as
                // a mirror weighted by its reflectance (smooth) or as a glossy vertex (rough).
                // The path never branches here (the base traces no ray on), so a plastic needs
                // no sampled split: it costs what a mirror costs plus a diffuse end point.
                const PlasticBsdf coat(mat);
                const float cosO = std::clamp(-glm::dot(glm::normalize(dir), ns), 0.0f, 1.0f);
                shadeDiffuse(px, hit, mat, ns, ng, path.throughput * path.weight * coat.viewShare(cosO), &coat);
                if (path.depth >= ctx.settings.maxDepth) break;
                if (!coat.smooth()) {
                    shadeGlossy(px, hit, dir, ns, ng, path);
                    break;
                }
                Vec3 r = glm::normalize(reflect(dir, ns));
                if (glm::dot(r, ng) <= 0.0f) r = glm::normalize(reflect(dir, ng));
                path.throughput *= coat.coatFresnel(cosO);
                path.ray = Ray{es.offsetOrigin(hit.position, ng, r), r};
                ++path.depth;
                if (maxComponent(path.throughput) < kMinThroughput) break;
                continue;
            }
            if (mat.isPartlyDiffuse()) {
                // Deterministic split of a partly transmissive material: the Lambertian share
                // (1 − t) ends here, the dielectric share t continues below.
                shadeDiffuse(px, hit, mat, ns, ng, path.throughput * path.weight * (1.0f - mat.transmission));
                path.throughput *= mat.transmission;
                if (maxComponent(path.throughput) < kMinThroughput) break;
            }
            if (path.depth >= ctx.settings.maxDepth) break;

            if (mat.isGlossy()) {
                shadeGlossy(px, hit, dir, ns, ng, path);
                break;
            }

            if (mat.type == MaterialType::Mirror) {
                // Reflect about the shading normal; if that sends the ray into the surface (strong
                // normal interpolation at grazing angles) use the geometric normal instead.
                Vec3 r = glm::normalize(reflect(dir, ns));
                if (glm::dot(r, ng) <= 0.0f) r = glm::normalize(reflect(dir, ng));
                path.throughput *= mat.baseColor;
                path.ray = Ray{es.offsetOrigin(hit.position, ng, r), r};
                ++path.depth;
                if (maxComponent(path.throughput) < kMinThroughput) break;
                continue;
            }

            if (splitDielectric(px, hit, mat, dir, ns, ng, path, stack, top)) continue;
            break;
        }
    }
    if (!finite(result.direct)) {
        result.direct = Vec3(0.0f);
        ++count.nonFinite;
    }
    return result;
}

}  // namespace

void renderSet(const EmbreeScene& scene, const Camera& camera, const EyeSettings& settings,
               const Interleave& pattern, int set, const CausticEstimator* caustics,
               std::span<PixelRadiance> out, EyeStats* stats, EyeRecords* records, uint64_t sampleSeed,
               bool recordLights) {
    RTPM_CHECK(set >= 0 && set < pattern.setCount());
    RTPM_CHECK(out.size() == size_t(pattern.pixelCount(set)));
    Context context = makeContext(scene, settings, caustics, set);
    context.sampleSeed = sampleSeed;
    context.recordLights = recordLights;
    const Context& ctx = context;
    const int rows = pattern.setRows(set);
    const int cols = pattern.setColumns(set);
    // Record mode: each row's hits go to their own vector, concatenated in row order afterwards,
    // so the record order does not depend on the thread count.
    std::vector<std::vector<EyeHit>> rowHits(records ? size_t(rows) : 0);
    std::atomic<uint64_t> primary{0}, secondary{0}, shadow{0}, nonFinite{0}, overflow{0}, sampled{0};
    const Camera::PixelRays pixelRays = camera.pixelRays(pattern.width, pattern.height);
    tbb::parallel_for(tbb::blocked_range<int>(0, rows), [&](const tbb::blocked_range<int>& range) {
        Counters count;
        std::vector<PathState> stack(kStackSize);
        Ray rays[8];
        SurfaceHit firstHits[8];
        std::vector<CausticRequest> requests;
        std::vector<CausticQuery> queries;
        std::vector<Vec3> answers;
        for (int r = range.begin(); r < range.end(); ++r) {
            GatherHint hint;  // per row: what a pixel's neighbours hint does not depend on threads
            for (int c0 = 0; c0 < cols; c0 += 8) {
                // Primary rays of 8 neighbouring pixels of the row as one coherent Embree packet.
                const int lanes = std::min(8, cols - c0);
                for (int l = 0; l < lanes; ++l) {
                    const int n = r * cols + c0 + l;
                    rays[l] = Ray{camera.position,
                                  pixelRays.direction(pattern.pixelX(set, n), pattern.pixelY(set, n))};
                }
                const uint32_t hitMask = ctx.es.intersect8(rays, lanes, firstHits);
                requests.clear();
                for (int l = 0; l < lanes; ++l) {
                    const int n = r * cols + c0 + l;
                    out[size_t(n)] = shadePixel(ctx, pattern.pixelX(set, n), pattern.pixelY(set, n), rays[l],
                                                (hitMask >> l) & 1u ? &firstHits[l] : nullptr, stack.data(),
                                                count, requests, l, records ? &rowHits[size_t(r)] : nullptr,
                                                uint32_t(n));
                }
                // The packet's caustic lookups as one group (neighbouring hits share their search).
                answerCaustics(ctx, requests, queries, answers, hint, out.subspan(size_t(r * cols + c0), size_t(lanes)),
                               count);
            }
        }
        primary += count.primary;
        secondary += count.secondary;
        shadow += count.shadow;
        nonFinite += count.nonFinite;
        overflow += count.stackOverflow;
        sampled += count.sampledSplits;
    });
    if (records) {
        records->hits.clear();
        for (const auto& row : rowHits) records->hits.insert(records->hits.end(), row.begin(), row.end());
        records->firstHit.assign(out.size() + 1, 0);
        for (const EyeHit& e : records->hits) ++records->firstHit[e.pixel + 1];
        for (size_t i = 1; i < records->firstHit.size(); ++i) records->firstHit[i] += records->firstHit[i - 1];
    }
    if (stats) {
        stats->primaryRays += primary;
        stats->secondaryRays += secondary;
        stats->shadowRays += shadow;
        stats->nonFinite += nonFinite;
        stats->stackOverflows += overflow;
        stats->sampledSplits += sampled;
    }
}

void relightSet(const EmbreeScene& scene, const EyeSettings& settings, const Interleave& pattern, int set,
                const CausticEstimator* caustics, const EyeRecords& records, std::span<const Vec3> base,
                std::span<PixelRadiance> out, EyeStats* stats) {
    RTPM_CHECK(set >= 0 && set < pattern.setCount());
    RTPM_CHECK(out.size() == size_t(pattern.pixelCount(set)) && base.size() == out.size());
    RTPM_CHECK(records.firstHit.size() == out.size() + 1);
    const Context context = makeContext(scene, settings, caustics, set);
    const Context& ctx = context;
    const int rows = pattern.setRows(set);
    const int cols = pattern.setColumns(set);
    std::atomic<uint64_t> secondary{0}, shadow{0}, nonFinite{0};
    tbb::parallel_for(tbb::blocked_range<int>(0, rows), [&](const tbb::blocked_range<int>& range) {
        Counters count;
        std::vector<CausticRequest> requests;
        std::vector<CausticQuery> queries;
        std::vector<Vec3> answers;
        for (int r = range.begin(); r < range.end(); ++r) {
            GatherHint hint;  // per row, as renderSet's
            for (int c0 = 0; c0 < cols; c0 += 8) {
                const int lanes = std::min(8, cols - c0);
                requests.clear();
                for (int l = 0; l < lanes; ++l) {
                    const size_t n = size_t(r * cols + c0 + l);
                    PixelRadiance px{base[n], Vec3(0.0f)};
                    for (uint32_t k = records.firstHit[n]; k < records.firstHit[n + 1]; ++k) {
                        const EyeHit& e = records.hits[k];
                        const Material& m = ctx.scene.materials[e.hit.material];
                        if (e.kind == EyeHit::Kind::Glossy) {
                            const GlossyRadiance g =
                                glossyTree(ctx, uint32_t(set), e.hit, -e.wo, e.geometricNormal, e.normal, e.depth,
                                           e.rotation, 0, settings.glossySamples, GlossyCaustic::Lookup, count);
                            px.direct += e.throughput * g.direct;
                            px.caustic += e.throughput * g.caustic;
                        } else if (e.kind == EyeHit::Kind::EndPoint) {
                            std::optional<PlasticBsdf> coat;  // a plastic's base: lit through its coat
                            if (m.type == MaterialType::Plastic) coat.emplace(m);
                            px.direct += e.throughput * directLight(ctx, e.hit, e.normal, e.geometricNormal, e.albedo,
                                                                    e.rotation, count, coat ? &*coat : nullptr);
                            if (caustics) requests.push_back(CausticRequest{e.hit, e.normal, e.albedo, e.throughput, l});
                        }
                    }
                    if (!finite(px.direct)) {
                        px.direct = Vec3(0.0f);
                        ++count.nonFinite;
                    }
                    out[n] = px;
                }
                answerCaustics(ctx, requests, queries, answers, hint, out.subspan(size_t(r * cols + c0), size_t(lanes)),
                               count);
            }
        }
        secondary += count.secondary;
        shadow += count.shadow;
        nonFinite += count.nonFinite;
    });
    if (stats) {
        stats->secondaryRays += secondary;
        stats->shadowRays += shadow;
        stats->nonFinite += nonFinite;
    }
}

struct AreaLightSampler::Impl {
    Context ctx;
    bool glossy;  // the scene has a glossy material
};

AreaLightSampler::AreaLightSampler(const EmbreeScene& scene, const EyeSettings& settings)
    : impl_(std::make_unique<Impl>(Impl{makeContext(scene, settings, nullptr, 0),
                                        std::any_of(scene.scene().materials.begin(), scene.scene().materials.end(),
                                                    [](const Material& m) { return m.isGlossy(); })})) {}

AreaLightSampler::~AreaLightSampler() = default;

bool AreaLightSampler::empty() const {
    return impl_->ctx.es.emissiveTriangles().empty() && !impl_->glossy && !impl_->ctx.environment;
}

Vec3 AreaLightSampler::sample(const EyeHit& e, uint32_t pass, uint64_t& shadowRays) const {
    // Pass p rotates the pixel's rotation by p steps of the R3 sequence (Roberts 2018: the
    // generalised golden ratio φ₃ = 1.2207…, steps 1/φ₃, 1/φ₃², 1/φ₃³), so successive passes
    // stratify each other's samples; pass 0 is the eye pass's own rotation.
    constexpr double kStep[3] = {0.8191725133961645, 0.6710436067037893, 0.5497004779019703};
    std::array<float, 3> rot = e.rotation;
    for (int d = 0; d < 3; ++d) {
        const double shifted = double(rot[d]) + double(pass) * kStep[d];
        rot[d] = wrap01(float(shifted - std::floor(shifted)));
    }
    Counters count;
    Vec3 v(0.0f);
    if (e.kind == EyeHit::Kind::Glossy) {
        v = glossyTree(impl_->ctx, e.set, e.hit, -e.wo, e.geometricNormal, e.normal, int(e.depth), rot, pass, 1,
                       GlossyCaustic::Skip, count).direct;
    } else if (e.kind == EyeHit::Kind::EndPoint) {
        const Material& m = impl_->ctx.scene.materials[e.hit.material];
        if (m.type == MaterialType::Plastic) {
            const PlasticBsdf coat(m);
            v = areaLight(impl_->ctx, e.hit, e.normal, e.geometricNormal, e.albedo, rot, count, Vec3(0.0f), &coat);
        } else {
            v = areaLight(impl_->ctx, e.hit, e.normal, e.geometricNormal, e.albedo, rot, count, Vec3(0.0f));
        }
    }
    shadowRays += count.shadow;
    return finite(v) ? v : Vec3(0.0f);
}

}  // namespace rtpm