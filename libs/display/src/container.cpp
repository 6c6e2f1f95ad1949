// Convex containers (Bimber et al. section 7.1): OBB from principal axes, coarse convex hull by
// incremental construction over extreme points, Moller-Trumbore intersection.

#include <plx/display/container.h>

#include <algorithm>
#include <array>
#include <cmath>

namespace plx::display {
namespace {

// Eigenvectors of a symmetric 3x3 matrix by cyclic Jacobi rotations (columns of the result).
glm::dmat3 symmetricEigenvectors(glm::dmat3 a) {
    glm::dmat3 v(1.0);
    for (int sweep = 0; sweep < 32; ++sweep) {
        double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        if (off < 1e-24) break;
        for (int p = 0; p < 2; ++p) {
            for (int q = p + 1; q < 3; ++q) {
                if (std::fabs(a[p][q]) < 1e-30) continue;
                double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                double t = (theta >= 0 ? 1.0 : -1.0) /
                           (std::fabs(theta) + std::sqrt(theta * theta + 1.0));
                double c = 1.0 / std::sqrt(t * t + 1.0), s = t * c;
                glm::dmat3 j(1.0);
                j[p][p] = c, j[q][q] = c, j[p][q] = s, j[q][p] = -s;
                a = glm::transpose(j) * a * j;
                v = v * j;
            }
        }
    }
    return v;
}

Container boxContainer(const DVec3& centre, const std::array<DVec3, 3>& axes, const DVec3& lo,
                       const DVec3& hi) {
    Container c;
    c.kind = ContainerKind::kObb;
    for (int i = 0; i < 8; ++i) {
        DVec3 local((i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z);
        c.verticesMm.push_back(centre + local.x * axes[0] + local.y * axes[1] +
                               local.z * axes[2]);
    }
    // Faces of the unit cube by corner bit pattern (x = bit 0, y = bit 1, z = bit 2).
    static const uint32_t kQuads[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4},
                                          {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
    for (const auto& q : kQuads) {
        for (uint32_t idx : {q[0], q[1], q[2], q[0], q[2], q[3]}) c.indices.push_back(idx);
    }
    // Orient every face outwards (a left-handed axis frame flips them all).
    DVec3 mid(0.0);
    for (const DVec3& p : c.verticesMm) mid += p / 8.0;
    for (size_t t = 0; t < c.indices.size(); t += 3) {
        const DVec3& a = c.verticesMm[c.indices[t]];
        DVec3 n = glm::cross(c.verticesMm[c.indices[t + 1]] - a, c.verticesMm[c.indices[t + 2]] - a);
        if (glm::dot(n, a - mid) < 0.0) std::swap(c.indices[t + 1], c.indices[t + 2]);
    }
    return c;
}

// Polytope bounded by the planes n_i . x <= d_i: vertices from plane triples inside all planes,
// faces as the vertices on each plane sorted around their centre (fan-triangulated).
bool polytopeFromPlanes(const std::vector<DVec3>& normals, const std::vector<double>& offsets,
                        double eps, Container* out) {
    size_t n = normals.size();
    std::vector<DVec3> verts;
    for (size_t i = 0; i < n; ++i)
        for (size_t j = i + 1; j < n; ++j)
            for (size_t k = j + 1; k < n; ++k) {
                glm::dmat3 m = glm::transpose(glm::dmat3(normals[i], normals[j], normals[k]));
                if (std::fabs(glm::determinant(m)) < 1e-9) continue;
                DVec3 p = glm::inverse(m) * DVec3(offsets[i], offsets[j], offsets[k]);
                bool inside = true;
                for (size_t q = 0; q < n && inside; ++q)
                    inside = glm::dot(normals[q], p) <= offsets[q] + eps;
                if (!inside) continue;
                bool dup = false;
                for (const DVec3& v : verts) dup = dup || glm::length(v - p) < eps;
                if (!dup) verts.push_back(p);
            }
    if (verts.size() < 4) return false;
    out->verticesMm = verts;
    for (size_t f = 0; f < n; ++f) {
        std::vector<uint32_t> on;
        DVec3 centre(0.0);
        for (size_t v = 0; v < verts.size(); ++v)
            if (std::fabs(glm::dot(normals[f], verts[v]) - offsets[f]) < eps)
                on.push_back(uint32_t(v)), centre += verts[v];
        if (on.size() < 3) continue;
        centre /= double(on.size());
        DVec3 u = glm::normalize(verts[on[0]] - centre);
        DVec3 w = glm::cross(normals[f], u);
        std::sort(on.begin(), on.end(), [&](uint32_t a, uint32_t b) {
            DVec3 da = verts[a] - centre, db = verts[b] - centre;
            return std::atan2(glm::dot(da, w), glm::dot(da, u)) <
                   std::atan2(glm::dot(db, w), glm::dot(db, u));
        });
        for (size_t t = 1; t + 1 < on.size(); ++t) {
            for (uint32_t idx : {on[0], on[t], on[t + 1]}) out->indices.push_back(idx);
        }
    }
    return true;
}

}  // namespace

Result<ContainerKind> parseContainerKind(const std::string& name) {
    if (name == "none") return ContainerKind::kNone;
    if (name == "obb") return ContainerKind::kObb;
    if (name == "hull") return ContainerKind::kHull;
    return errorStatus(ErrorCode::kInvalidArgument,
                       "unknown container '" + name + "' (expected obb, hull or none)");
}

const char* containerKindName(ContainerKind kind) {
    switch (kind) {
    case ContainerKind::kObb: return "obb";
    case ContainerKind::kHull: return "hull";
    default: return "none";
    }
}

Container makeObbContainer(std::span<const DVec3> pointsMm) {
    PLX_CHECK(!pointsMm.empty());
    DVec3 mean(0.0);
    for (const DVec3& p : pointsMm) mean += p;
    mean /= double(pointsMm.size());
    glm::dmat3 cov(0.0);
    for (const DVec3& p : pointsMm) {
        DVec3 d = p - mean;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) cov[c][r] += d[r] * d[c];
    }
    glm::dmat3 ev = symmetricEigenvectors(cov);
    std::array<DVec3, 3> axes = {glm::normalize(ev[0]), glm::normalize(ev[1]),
                                 glm::normalize(ev[2])};
    DVec3 lo(1e300), hi(-1e300);
    for (const DVec3& p : pointsMm) {
        DVec3 d = p - mean;
        DVec3 local(glm::dot(d, axes[0]), glm::dot(d, axes[1]), glm::dot(d, axes[2]));
        lo = glm::min(lo, local);
        hi = glm::max(hi, local);
    }
    // A flat scene still gets a closed box (a sliver 1 micrometre thick).
    for (int a = 0; a < 3; ++a)
        if (hi[a] - lo[a] < 1e-3) lo[a] -= 5e-4, hi[a] += 5e-4;
    return boxContainer(mean, axes, lo, hi);
}

Container makeHullContainer(std::span<const DVec3> pointsMm) {
    PLX_CHECK(!pointsMm.empty());
    // A 26-DOP: the support planes of the points along the cube's axes, face diagonals and
    // corner diagonals. It contains every point (conservative, so no content is ever culled)
    // and has at most 26 faces, the "very coarse but tighter convex hull" of section 7.1.
    std::vector<DVec3> normals;
    std::vector<double> offsets;
    for (int x = -1; x <= 1; ++x)
        for (int y = -1; y <= 1; ++y)
            for (int z = -1; z <= 1; ++z) {
                if (!x && !y && !z) continue;
                DVec3 d = glm::normalize(DVec3(x, y, z));
                double best = -1e300;
                for (const DVec3& p : pointsMm) best = std::max(best, glm::dot(p, d));
                normals.push_back(d);
                offsets.push_back(best);
            }
    double size = 0.0;
    for (size_t i = 0; i < 3; ++i) size = std::max(size, offsets[i] + offsets[25 - i]);
    Container c;
    c.kind = ContainerKind::kHull;
    if (!polytopeFromPlanes(normals, offsets, 1e-7 * std::max(size, 1.0) + 1e-9, &c)) {
        c = makeObbContainer(pointsMm);  // flat or single-point scenes
        c.kind = ContainerKind::kHull;
    }
    return c;
}

Container makeContainer(ContainerKind kind, std::span<const DVec3> pointsMm) {
    switch (kind) {
    case ContainerKind::kObb: return makeObbContainer(pointsMm);
    case ContainerKind::kHull: return makeHullContainer(pointsMm);
    default: return {};
    }
}

TriangleFromOrigin prepareFromOrigin(const DVec3& o, const DVec3& a, const DVec3& b,
                                     const DVec3& c) {
    TriangleFromOrigin tri;
    tri.e1 = b - a, tri.e2 = c - a;
    tri.s = o - a;
    tri.q = glm::cross(tri.s, tri.e1);
    return tri;
}

bool intersectFromOrigin(const TriangleFromOrigin& tri, const DVec3& d, double* t) {
    DVec3 p = glm::cross(d, tri.e2);
    double det = glm::dot(tri.e1, p);
    if (std::fabs(det) < 1e-14) return false;
    double inv = 1.0 / det;
    double u = glm::dot(tri.s, p) * inv;
    if (u < -1e-9 || u > 1.0 + 1e-9) return false;
    double v = glm::dot(d, tri.q) * inv;
    if (v < -1e-9 || u + v > 1.0 + 1e-9) return false;
    *t = glm::dot(tri.e2, tri.q) * inv;
    return *t > 0.0;
}

bool intersectTriangle(const DVec3& o, const DVec3& d, const DVec3& a, const DVec3& b,
                       const DVec3& c, double* t) {
    return intersectFromOrigin(prepareFromOrigin(o, a, b, c), d, t);
}

bool containerContains(const Container& container, const DVec3& p, double toleranceMm) {
    for (size_t t = 0; t < container.indices.size(); t += 3) {
        const DVec3& a = container.verticesMm[container.indices[t]];
        DVec3 n = glm::normalize(glm::cross(container.verticesMm[container.indices[t + 1]] - a,
                                            container.verticesMm[container.indices[t + 2]] - a));
        if (glm::dot(n, p - a) > toleranceMm) return false;
    }
    return true;
}

}  // namespace plx::display
