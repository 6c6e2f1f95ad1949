#pragma once
// Smooth per-corner normals for meshes a file gives without normals (used by import.cpp).

#include <array>
#include <vector>

#include <plx/core/math.h>

namespace plx::scene {

// Corners of one triangle: indices into a position array.
using Corners = std::array<unsigned, 3>;

// Largest number of faces around one position for which the smoothing angle is honoured
// pairwise; busier positions (huge fans) get one averaged normal, summed once per position,
// so the work stays linear in the corners (at most this many terms per corner).
constexpr size_t kMaxPairwiseFaces = 256;

// Around each position, the sum of the area-weighted normals of the faces within 80 degrees of
// the corner's own face (box edges stay sharp, curved surfaces look smooth). Returns one
// unnormalised normal per corner (3 per triangle). Positions are grouped by exact bits.
std::vector<Vec3> smoothCornerNormals(const std::vector<Vec3>& pos,
                                      const std::vector<Corners>& tris);

}  // namespace plx::scene
