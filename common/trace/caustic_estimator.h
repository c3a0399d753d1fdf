// The interface through which the eye pass asks for caustic radiance; photon maps implement it.
#pragma once

#include <cstdint>
#include <span>

#include "common/core/math.h"
#include "common/trace/embree_scene.h"

namespace rtpm {

/// What one caustic query (or group of queries, radianceGroup) leaves for the next one nearby:
/// the squared radius of its estimate (a group's: the largest of its full k-NN gathers, or
/// rMax² when none found k photons: sparse photons, search all of rMax; 0 = none). The eye pass
/// keeps one per image row and resets it at the row's start, so the hints a query sees do not
/// depend on the thread count or the set split.
struct GatherHint {
    float radius2 = 0.0f;
    /// For lookups among a few nearest points (IrradiancePoints): the last query's position and
    /// normal and the distance of the farthest of the points it held, negative when it held
    /// fewer. The next query with the same normal searches no farther than that distance plus
    /// the step between the two: the same points face it, so its nearest lie within.
    Vec3 lastPosition{0.0f};
    Vec3 lastNormal{0.0f};
    float lastReach = -1.0f;
};

/// One query of a group (CausticEstimator::radianceGroup): a diffuse hit, its shading normal
/// facing the viewer and its diffuse reflectance.
struct CausticQuery {
    const SurfaceHit* hit = nullptr;
    Vec3 normal{0.0f};
    Vec3 albedo{0.0f};
};

/// Caustic radiance at a diffuse hit of `scene` from the photon map of interleaving set `set`.
/// `normal` is the shading normal facing the viewer; `albedo` the diffuse reflectance there.
/// `scene` is passed on every call (an estimator keeps no scene of its own) for estimators that
/// cast rays, e.g. a visibility test per gathered photon.
/// `hint` (optional) carries a neighbouring query's radius in and this one's out; an estimator may
/// use it to search faster but must return what it returns without it.
/// Must be thread-safe (called from many TBB threads at once).
class CausticEstimator {
public:
    virtual ~CausticEstimator() = default;
    virtual Vec3 radiance(const EmbreeScene& scene, uint32_t set, const SurfaceHit& hit, Vec3 normal,
                         Vec3 albedo, GatherHint* hint = nullptr) const = 0;
    /// The radiance of each of `queries` (neighbouring pixels' hits of set `set`, in pixel
    /// order) into `out` (same size): what `radiance` answers for each, with `hint` carried
    /// from one group to the next. An estimator may share work between nearby queries; the
    /// default asks `radiance` once per query. Must be thread-safe.
    virtual void radianceGroup(const EmbreeScene& scene, uint32_t set, std::span<const CausticQuery> queries,
                               std::span<Vec3> out, GatherHint* hint = nullptr) const {
        for (size_t i = 0; i < queries.size(); ++i)
            out[i] = radiance(scene, set, *queries[i].hit, queries[i].normal, queries[i].albedo, hint);
    }
};

}  // namespace rtpm
