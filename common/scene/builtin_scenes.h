// Procedural versions of the paper's scenes (RING, GLASS, EGG, HEADLIGHT) and a Cornell box.
#pragma once

#include <string>

#include "common/scene/scene.h"

namespace rtpm {

/// Builds the built-in scene `name` (upper case: RING, GLASS, EGG, HEADLIGHT, CORNELL).
/// Units are metres. Every scene has a camera showing its caustic and at least one light or
/// emissive material; solids are closed, with the geometric normal (counter-clockwise winding
/// seen from outside) pointing out of the solid, and carry smooth per-vertex normals where the
/// surface is smooth. Every mesh has one identity Instance (transforms are baked into vertices).
/// Throws SceneError for an unknown name. Deterministic. Cost O(triangles) (≤ ~150k).
Scene buildBuiltinScene(const std::string& name);

/// Metal (Mirror) ring band, ≈1k triangles, on a diffuse floor; a small emissive quad light low on
/// one side makes the nephroid ("cardioid") caustic inside the ring (paper Fig. 1a, 3).
Scene buildRingScene();
/// Cognac glass (Dielectric 1.5) holding amber liquid (Dielectric 1.33 with absorption),
/// ≈20k triangles, on a table lit by a point light; the focused caustic lies on the table (Fig. 1b).
Scene buildGlassScene();
/// Glass egg (Dielectric 1.5), ≈4k triangles, on a floor; a point light makes a focused caustic
/// inside its shadow.
Scene buildEggScene();
/// Car headlight (Fig. 1c): emissive filament box in a glass bulb shell at the focus of a
/// parabolic Mirror reflector, a curved glass front cover, and a diffuse wall 3 m ahead
/// receiving the beam pattern; ≈150k triangles.
Scene buildHeadlightScene();
/// Cornell box (red/green side walls, white floor/ceiling/back, emissive ceiling quad) with a
/// glass sphere and a mirror sphere.
Scene buildCornellScene();

}  // namespace rtpm
