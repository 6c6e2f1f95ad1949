// Homogeneous clipping (Sutherland-Hodgman in clip space) against the near and far planes and
// the guard band. Only triangles whose outcodes ask for it come here; most are snapped directly.

#include <array>

#include "pipeline.h"

namespace plx::raster::detail {
namespace {

struct ClipVertex {
    Vec4 pos;
    Vec3 bary;
};

constexpr int kMaxPolygon = 3 + 6;  // each of the 6 planes adds at most one vertex

// Signed distance of a vertex to plane p (inside when >= 0).
float planeDistance(const Vec4& c, int plane, const Viewport& vp) {
    switch (plane) {
        case 0: return c.z + c.w;              // near
        case 1: return c.w - c.z;              // far
        case 2: return vp.guardX * c.w - c.x;  // guard right
        case 3: return vp.guardX * c.w + c.x;  // guard left
        case 4: return vp.guardY * c.w - c.y;  // guard top
        default: return vp.guardY * c.w + c.y;  // guard bottom
    }
}

int clipAgainstPlane(const ClipVertex* in, int n, int plane, const Viewport& vp, ClipVertex* out) {
    int m = 0;
    for (int i = 0; i < n; ++i) {
        const ClipVertex& a = in[i];
        const ClipVertex& b = in[(i + 1) % n];
        float da = planeDistance(a.pos, plane, vp), db = planeDistance(b.pos, plane, vp);
        if (da >= 0.0f) out[m++] = a;
        if ((da >= 0.0f) != (db >= 0.0f)) {
            float t = da / (da - db);
            out[m++] = {a.pos + t * (b.pos - a.pos), a.bary + t * (b.bary - a.bary)};
        }
    }
    return m;
}

}  // namespace

int clipTriangle(const Vec4 clip[3], const Viewport& vp, RasterVertex out[][3]) {
    std::array<ClipVertex, kMaxPolygon> bufA, bufB;
    ClipVertex* cur = bufA.data();
    ClipVertex* next = bufB.data();
    cur[0] = {clip[0], Vec3(1, 0, 0)};
    cur[1] = {clip[1], Vec3(0, 1, 0)};
    cur[2] = {clip[2], Vec3(0, 0, 1)};
    int n = 3;
    for (int plane = 0; plane < 6 && n >= 3; ++plane) {
        bool anyOutside = false;
        for (int i = 0; i < n; ++i) anyOutside |= planeDistance(cur[i].pos, plane, vp) < 0.0f;
        if (!anyOutside) continue;
        n = clipAgainstPlane(cur, n, plane, vp, next);
        std::swap(cur, next);
    }
    if (n < 3) return 0;
    RasterVertex snapped[kMaxPolygon];
    for (int i = 0; i < n; ++i) {
        // After the near plane w >= near > 0, except for rounding at the plane itself.
        if (!(cur[i].pos.w > 0.0f)) return 0;
        snapped[i] = snapVertex(cur[i].pos, vp, cur[i].bary);
    }
    int count = 0;
    for (int i = 1; i + 1 < n && count < kMaxClippedTriangles; ++i) {
        out[count][0] = snapped[0];
        out[count][1] = snapped[i];
        out[count][2] = snapped[i + 1];
        ++count;
    }
    return count;
}

}  // namespace plx::raster::detail
