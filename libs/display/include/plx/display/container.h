#pragma once
// The scene's convex container of Bimber et al. section 7.1: an oriented bounding box or a coarse
// convex hull of the scene's points, as a closed triangle mesh with outward (counter-clockwise)
// faces. GeneratePatch intersects lines of sight with it to skip image patches that show no scene.

#include <span>
#include <vector>

#include <plx/core/status.h>
#include <plx/display/optics.h>

namespace plx::display {

enum class ContainerKind { kNone, kObb, kHull };

// Parses "none", "obb", "hull".
Result<ContainerKind> parseContainerKind(const std::string& name);
const char* containerKindName(ContainerKind kind);

struct Container {
    ContainerKind kind = ContainerKind::kNone;
    std::vector<DVec3> verticesMm;
    std::vector<uint32_t> indices;  // three per triangle, counter-clockwise seen from outside
    size_t triangleCount() const { return indices.size() / 3; }
};

// Oriented bounding box from the principal axes of the points (covariance eigenvectors).
// Preconditions: at least one point, all finite.
Container makeObbContainer(std::span<const DVec3> pointsMm);

// Coarse convex hull: the 26-DOP of the points (support planes along the axes, face and corner
// diagonals of a cube), so its size stays small whatever the scene and it contains every point.
// Falls back to the OBB when the points are (nearly) coplanar.
// Preconditions: at least one point, all finite.
Container makeHullContainer(std::span<const DVec3> pointsMm);

// Container of the given kind (kNone gives an empty container that culls nothing).
Container makeContainer(ContainerKind kind, std::span<const DVec3> pointsMm);

// Moller-Trumbore ray-triangle test (Moller and Trumbore 1997, the paper's [18]): true and the
// ray parameter when o + t d with t > 0 meets triangle (a, b, c).
bool intersectTriangle(const DVec3& o, const DVec3& d, const DVec3& a, const DVec3& b,
                       const DVec3& c, double* t);

// The same test for many rays from one origin (GeneratePatch's lines of sight all start at the
// eye): the terms that do not depend on the direction (the two edges, the origin relative to a
// and its cross product with the first edge) are computed once per triangle.
// intersectFromOrigin(prepareFromOrigin(o, a, b, c), d, &t) == intersectTriangle(o, d, a, b, c, &t)
// bit for bit.
struct TriangleFromOrigin {
    DVec3 e1, e2;  // b - a, c - a
    DVec3 s;       // o - a
    DVec3 q;       // cross(s, e1)
};
TriangleFromOrigin prepareFromOrigin(const DVec3& o, const DVec3& a, const DVec3& b,
                                     const DVec3& c);
bool intersectFromOrigin(const TriangleFromOrigin& tri, const DVec3& d, double* t);

// Whether a point lies inside or on the closed container (all face planes).
bool containerContains(const Container& container, const DVec3& p, double toleranceMm = 1e-6);

}  // namespace plx::display
