#pragma once
// Appending simple solids to a Mesh, for the procedural generators and for tests: quads, boxes
// and cylinders whose faces are wound counter-clockwise seen from outside (front faces), with
// outward normals and UVs. UV (0,0) is the top-left texel of a texture.

#include <plx/scene/scene.h>

namespace plx::scene {

// Appends the quad corner, corner+edgeU, corner+edgeU+edgeV, corner+edgeV as two triangles
// facing edgeU x edgeV, with the four UVs in that order. Precondition: the edges are not parallel.
void appendQuad(Mesh* mesh, const Vec3& corner, const Vec3& edgeU, const Vec3& edgeV,
                const Vec2 uvs[4]);

// Appends a box (12 triangles, flat normals) centred at center with the given half extents,
// turned by yawRadians about the vertical axis through its centre. UVs are the face's
// coordinates in scene units divided by uvMetres (so textures tile every uvMetres).
// Preconditions: halfExtents > 0 on every axis, uvMetres > 0.
void appendBox(Mesh* mesh, const Vec3& center, const Vec3& halfExtents, float yawRadians = 0.0f,
               float uvMetres = 1.0f);

// Appends a vertical cylinder (4 * segments triangles: smooth sides, flat caps) standing on
// baseCenter. Preconditions: radius > 0, height > 0, segments >= 3.
void appendCylinder(Mesh* mesh, const Vec3& baseCenter, float radius, float height,
                    int segments);

}  // namespace plx::scene
