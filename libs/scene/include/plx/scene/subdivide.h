#pragma once
// Midpoint (1-to-4) subdivision: makes denser meshes of the same shape from a real model, for
// benchmarks that need 100k to 1M triangles when only a smaller file is at hand.

#include <plx/scene/scene.h>

namespace plx::scene {

// Largest level count accepted: each level multiplies the triangle count by 4.
constexpr int kMaxSubdivisionLevels = 8;
// Largest triangle count the result may have (the importer's default limit).
constexpr size_t kMaxSubdividedTriangles = size_t(1) << 28;

// Splits every triangle (a, b, c) into four, (a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca),
// `levels` times, with ab the midpoint of edge ab. Edge midpoints are shared between the two
// triangles of an edge, so meshes stay indexed. Positions and UVs are interpolated linearly and
// normals are interpolated and renormalised, so the surface, its bounds, winding, materials,
// textures and viewpoints are unchanged; only the tessellation gets 4^levels times denser.
// Triangle i of a mesh becomes triangles 4i .. 4i+3 at each level, so a mesh keeps its order.
// Preconditions: the scene is finalised. Errors: levels outside [0, kMaxSubdivisionLevels], a
// result above kMaxSubdividedTriangles triangles, or finalize() failing on the result.
Result<Scene> subdivideMidpoint(const Scene& scene, int levels);

}  // namespace plx::scene
