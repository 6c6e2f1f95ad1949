#pragma once
// Private pieces of the raster pipeline shared by the tiled renderer and the scalar reference:
// fixed-point vertex snapping, outcodes, homogeneous clipping, triangle setup and shading.
//
// Fixed-point format: screen positions are int32 in 1/256 pixel (8 sub-pixel bits, "24.8").
// Vertices are kept inside a guard band of +-kGuardPixels pixels, so coordinate differences
// fit in 2^24 and edge-function values (products of two differences) in 2^49: int64 is exact.
//
// The per-ISA kernels (tile_raster.inl, triangle_setup.inl, vertex_transform.inl) include this
// header too, so its inline helpers are `static`: each translation unit keeps its own copy,
// compiled with its own flags. Shared (COMDAT) copies could hand an AVX-512 body to a scalar
// caller (plx/core/isa_kernel.h; tests/portability checks the binary for it).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

#include <plx/core/cpu.h>
#include <plx/raster/raster.h>

namespace plx::raster::detail {

constexpr int kSubPixelBits = 8;
constexpr int kSubPixelScale = 1 << kSubPixelBits;
constexpr float kGuardPixels = 32768.0f;

// Outcode bits of a clip-space vertex.
enum : uint32_t {
    kOutLeft = 1, kOutRight = 2, kOutBottom = 4, kOutTop = 8, kOutNear = 16, kOutFar = 32,
    kOutGuard = 64,  // outside the guard band in x or y: needs clipping before snapping
    kOutFrustum = kOutLeft | kOutRight | kOutBottom | kOutTop | kOutNear | kOutFar,
    kOutNeedsClip = kOutNear | kOutFar | kOutGuard,
};

// checkRenderRequest, aborting (PLX_CHECK) with its message when the request is malformed.
void checkRenderRequestOrDie(const Camera& camera, const RenderOptions& options,
                             const RenderTargets& targets);

// Per-frame viewport constants derived from the camera.
struct Viewport {
    int width = 0, height = 0;
    float halfWidth = 0, halfHeight = 0;
    float guardX = 0, guardY = 0;  // guard band half-extent in clip units (|x| <= guardX * w)

    explicit Viewport(const Camera& camera);
};

static inline uint32_t outcode(const Vec4& c, const Viewport& vp) {
    uint32_t code = 0;
    if (c.x < -c.w) code |= kOutLeft;
    if (c.x > c.w) code |= kOutRight;
    if (c.y < -c.w) code |= kOutBottom;
    if (c.y > c.w) code |= kOutTop;
    if (c.z < -c.w) code |= kOutNear;
    if (c.z > c.w) code |= kOutFar;
    if (std::fabs(c.x) > vp.guardX * c.w || std::fabs(c.y) > vp.guardY * c.w) code |= kOutGuard;
    // NaN positions fail every comparison above; treat them as outside everything.
    if (!(c.w == c.w) || !(c.x == c.x) || !(c.y == c.y) || !(c.z == c.z)) code |= kOutFrustum;
    return code;
}

// A vertex ready for rasterisation: snapped screen position, 1/w, and its barycentric weights
// with respect to the original (unclipped) triangle's three vertices, for attributes.
struct RasterVertex {
    int32_t x = 0, y = 0;  // 1/256 pixel
    float invW = 0.0f;
    Vec3 bary{0.0f};
};

// Snaps a clip-space vertex inside the guard band (w > 0) to fixed point.
static inline RasterVertex snapVertex(const Vec4& c, const Viewport& vp, const Vec3& bary) {
    RasterVertex v;
    v.invW = 1.0f / c.w;
    float px = (c.x * v.invW) * vp.halfWidth + vp.halfWidth;
    float py = vp.halfHeight - (c.y * v.invW) * vp.halfHeight;
    v.x = int32_t(std::lrint(px * float(kSubPixelScale)));
    v.y = int32_t(std::lrint(py * float(kSubPixelScale)));
    v.bary = bary;
    return v;
}

// A transformed mesh vertex: its outcode, and, when the code has no kOutNeedsClip bit, its
// snapped position and 1/w (zero otherwise).
struct VertexOut {
    int32_t x, y;  // fixed point
    float invW;
    uint32_t code;
};

// Transforms positions[0 .. count) to clip space (clipFromWorld * (p, 1)), outcodes and snaps
// them into out[0 .. count). Per ISA (vertex_transform.inl), the same bits on every path.
PLX_ISA_DECLARE(void transformPositions(const Vec3* positions, size_t count,
                                        const Mat4& clipFromWorld, const Viewport& vp,
                                        VertexOut* out))

static inline int64_t edgeAt(int32_t ax, int32_t ay, int32_t bx, int32_t by, int64_t px,
                             int64_t py) {
    return int64_t(bx - ax) * (py - ay) - int64_t(by - ay) * (px - ax);
}

// First pixel whose centre (p*256 + 128) is >= v, and last pixel whose centre is <= v, for v
// inside the guard band (|v| < 2^24, so nothing overflows). The arithmetic shift is floor
// division: first = ceil((v - 128) / 256) = floor((v + 127) / 256), last = floor((v - 128) / 256).
static inline int firstPixelAtOrAfter(int32_t v) {
    return (v + kSubPixelScale / 2 - 1) >> kSubPixelBits;
}
static inline int lastPixelAtOrBefore(int32_t v) {
    return (v - kSubPixelScale / 2) >> kSubPixelBits;
}

// Top-left fill rule for edge (dx, dy) of a triangle with positive area: the interior lies where
// the edge function is positive, its gradient (-dy, dx) points inwards. Left edge: dy < 0; top
// edge: dy == 0 and dx > 0. Samples exactly on other edges are excluded by a bias of -1.
static inline int32_t topLeftBias(int32_t dx, int32_t dy) {
    return dy < 0 || (dy == 0 && dx > 0) ? 0 : -1;
}

// The vertices of a snapped triangle with doubled signed area `area2`, ordered so that the area
// is positive (vertices 1 and 2 swapped for front faces); returns the positive area.
static inline int64_t orientPositive(const RasterVertex vin[3], int64_t area2,
                                     const RasterVertex* v[3]) {
    v[0] = &vin[0], v[1] = &vin[1], v[2] = &vin[2];
    if (area2 >= 0) return area2;
    std::swap(v[1], v[2]);
    return -area2;
}

// Clips a triangle (clip-space positions) against the near and far planes and the guard band.
// Writes up to kMaxClippedTriangles triangles as RasterVertex triples; returns how many.
constexpr int kMaxClippedTriangles = 8;
int clipTriangle(const Vec4 clip[3], const Viewport& vp, RasterVertex out[][3]);

// Room for the pieces of one clipped triangle, left uninitialised: the clipping writes each piece
// it returns. For callers that clip one triangle at a time on a hot path (drawTriangleInSpans),
// where value-initialising 8 x 3 vertices took a tenth of the call's own time.
struct ClippedPieces {
    ClippedPieces() {}  // the union's vertices stay uninitialised
    union {
        RasterVertex tris[kMaxClippedTriangles][3];
    };
};

// Everything the pixel loop needs for one triangle, in the orientation where the signed area is
// positive (vertex order may be swapped from the mesh's).
struct TriangleSetup {
    int32_t x[3], y[3];   // fixed point
    int64_t area2 = 0;    // twice the area in (1/256 px)^2, > 0
    int64_t edgeBias[3];  // 0 for top-left edges, -1 otherwise (top-left fill rule)
    int minX = 0, minY = 0, maxX = -1, maxY = -1;  // inclusive pixel bounds, clamped to viewport
    int32_t extentX = 0, extentY = 0;  // TriangleBox's: max - min of x and y, in 1/256 pixel
    float invW[3];
    Vec3 color[3];  // linear lit colour at the vertices (Gouraud, textured)
    Vec2 uv[3];
    // Flat shading: the triangle's encoded colour, computed on the first sample that passes the
    // depth test (hidden triangles, often most of them, never pay for it).
    mutable Rgba8 flatColor;
    mutable bool flatReady = false;
    const scene::Scene* scene = nullptr;
    uint32_t meshIndex = 0, localTri = 0;
    uint32_t id = 0;  // global triangle index + 1
    const scene::Texture* texture = nullptr;
    // Screen-space derivatives (per pixel) of the barycentric weights b1 and b2, for texture LOD.
    float b1dx = 0, b1dy = 0, b2dx = 0, b2dy = 0;
    // Barycentric evaluation shared by every path (see rowBarycentrics): 1 / area2, and the
    // per-pixel x steps of b1 and b2.
    float invArea = 0, stepB1 = 0, stepB2 = 0;
};

// Barycentric weights b1, b2 (of vertices 1 and 2) at the first column minX of row y, from the
// exact integer edge values. Along the row, b = rowValue + float(x - minX) * step. The
// reference, the scalar loops and the AVX2 loops all evaluate exactly this expression, so their
// depth and attributes agree to the bit; the coverage test itself stays exact integer.
static inline void rowBarycentrics(const TriangleSetup& t, int y, float* b1Row, float* b2Row) {
    int64_t px = int64_t(t.minX) * kSubPixelScale + kSubPixelScale / 2;
    int64_t py = int64_t(y) * kSubPixelScale + kSubPixelScale / 2;
    *b1Row = float(edgeAt(t.x[2], t.y[2], t.x[0], t.y[0], px, py)) * t.invArea;
    *b2Row = float(edgeAt(t.x[0], t.y[0], t.x[1], t.y[1], px, py)) * t.invArea;
}

// Per-frame shading constants.
struct ShadeContext {
    Shading shading = Shading::kFlat;
    bool lit = true;
    Vec3 lightDir{0.0f, 1.0f, 0.0f};  // normalised
    float ambient = 0.25f;
    bool cullBackFaces = false;
    bool collectUnsampled = false;
    bool colorOnly = false;  // RenderOptions::colorOnly: no depth test, no depth or ID writes

    ShadeContext(const RenderOptions& options, const RenderTargets& targets);
};

// The identity part of a setup: the triangle's ID and where flat shading takes its colour from
// (computed on the first sample that needs it, flatColorFor).
static inline void setTriangleIdentity(const scene::Scene& scene, size_t meshIndex,
                                       uint32_t localTri, TriangleSetup* t) {
    t->id = uint32_t(scene.firstTriangle(meshIndex) + localTri + 1);
    t->scene = &scene;
    t->meshIndex = uint32_t(meshIndex);
    t->localTri = localTri;
    t->flatReady = false;
}

struct TriangleBox;
// Per ISA (triangle_setup.inl); the reference renderer takes the scalar definitions.
PLX_ISA_DECLARE(
    // Builds the setup of one (possibly clipped) triangle of mesh `meshIndex`, local triangle
    // `localTri`. Returns false when it covers no sample, is degenerate or is culled as
    // back-facing.
    bool setupTriangle(const scene::Scene& scene, size_t meshIndex, uint32_t localTri,
                       const RasterVertex v[3], const Viewport& vp, const ShadeContext& ctx,
                       TriangleSetup* out);
    // The same, for a triangle whose box (triangleBox returned true) is already known and whose
    // identity the caller has set (setTriangleIdentity; a flat colour already set is kept).
    void setupTriangleInBox(const scene::Scene& scene, size_t meshIndex, uint32_t localTri,
                            const RasterVertex v[3], const TriangleBox& box,
                            const ShadeContext& ctx, TriangleSetup* out);
    // Shades one covered sample. b1, b2: barycentric weights of vertices 1 and 2
    // (b0 = 1 - b1 - b2) in screen space; invW: interpolated 1/w at the sample.
    Rgba8 shadeSample(const TriangleSetup& t, const ShadeContext& ctx, float b1, float b2,
                      float invW))

// The scalar reference's front end for one scene-global triangle: transform, outcodes, and the
// clipped and snapped pieces (none when the triangle lies outside the frustum), written to
// out[0 .. return value) with the triangle's mesh and local index. Each piece then goes through
// isa_scalar::setupTriangle (renderReference), or through its steps triangleBox,
// setTriangleIdentity and setupTriangleInBox (drawTriangleInSpans, which clips by
// clipReferenceCorners and skips a piece that misses its spans before the setup).
int clipReferenceTriangle(const scene::Scene& scene, uint32_t globalTri, const Camera& camera,
                          const Viewport& vp, RasterVertex out[kMaxClippedTriangles][3],
                          size_t* meshIndex, uint32_t* localTri);
// Its transform, outcodes, clipping and snapping, for the triangle's three world-space corners.
int clipReferenceCorners(const Vec3 corners[3], const Camera& camera, const Viewport& vp,
                         RasterVertex out[kMaxClippedTriangles][3]);
// The encoded flat-shading colour of a mesh triangle (face normal Lambert + ambient).
Rgba8 flatColorOf(const scene::Scene& scene, size_t meshIndex, uint32_t localTri,
                  const ShadeContext& ctx);

// Lambert + ambient of a normal, two-sided (|n.l|) so open meshes look the same from both sides.
static inline float lambert(const Vec3& n, const ShadeContext& ctx) {
    return std::min(1.0f,
                    ctx.ambient + (1.0f - ctx.ambient) * std::fabs(glm::dot(n, ctx.lightDir)));
}

// Pixel bounds (inclusive, clamped to the viewport), doubled signed area and fixed-point extents
// of a snapped triangle.
struct TriangleBox {
    int minX = 0, minY = 0, maxX = -1, maxY = -1;
    int64_t area2 = 0;
    int32_t extentX = 0, extentY = 0;  // max - min of the vertices' x and y, in 1/256 pixel
};

// Cheap pre-test for binning and tiles: the box of a snapped triangle, false when it covers no
// sample centre, is degenerate, or is a back face that must be culled.
static inline bool triangleBox(const RasterVertex& a, const RasterVertex& b, const RasterVertex& c,
                               const Viewport& vp, bool cullBackFaces, TriangleBox* box) {
    box->area2 = edgeAt(a.x, a.y, b.x, b.y, c.x, c.y);
    // Positive area in y-down pixel coordinates means clockwise as displayed: a back face for
    // counter-clockwise front faces.
    if (box->area2 == 0 || (cullBackFaces && box->area2 > 0)) return false;
    const int32_t loX = std::min({a.x, b.x, c.x}), hiX = std::max({a.x, b.x, c.x});
    const int32_t loY = std::min({a.y, b.y, c.y}), hiY = std::max({a.y, b.y, c.y});
    box->extentX = hiX - loX;
    box->extentY = hiY - loY;
    box->minX = std::max(firstPixelAtOrAfter(loX), 0);
    box->minY = std::max(firstPixelAtOrAfter(loY), 0);
    box->maxX = std::min(lastPixelAtOrBefore(hiX), vp.width - 1);
    box->maxY = std::min(lastPixelAtOrBefore(hiY), vp.height - 1);
    return box->minX <= box->maxX && box->minY <= box->maxY;
}

static inline bool triangleBounds(const RasterVertex& a, const RasterVertex& b,
                                  const RasterVertex& c, const Viewport& vp, bool cullBackFaces,
                                  int* minX, int* minY, int* maxX, int* maxY) {
    TriangleBox box;
    bool covers = triangleBox(a, b, c, vp, cullBackFaces, &box);
    *minX = box.minX;
    *minY = box.minY;
    *maxX = box.maxX;
    *maxY = box.maxY;
    return covers;
}

static inline Rgba8 flatColorFor(const TriangleSetup& t, const ShadeContext& ctx) {
    if (!t.flatReady) {
        t.flatColor = flatColorOf(*t.scene, t.meshIndex, t.localTri, ctx);
        t.flatReady = true;
    }
    return t.flatColor;
}

// The reference's pixel loop over row y, columns x0..x1 inside the setup's box: coverage, depth
// test (unless ctx.colorOnly) and writes; returns the samples written. eAtX0: the three edge
// functions with their biases at the sample of (x0, y); step: their steps by a column
// (-(y[i + 1] - y[i]) * kSubPixelScale); b1Row, b2Row: the row's barycentrics at minX
// (rowBarycentrics). Inline: the span fill calls it for every span of a hole, a few pixels each.
static inline int64_t rasterizeReferencePixels(const TriangleSetup& t, const ShadeContext& ctx,
                                               const RenderTargets& rt, int y, int x0, int x1,
                                               const int64_t eAtX0[3], const int64_t step[3],
                                               float b1Row, float b2Row) {
    int64_t written = 0;
    // Flat: shadeSample's first case, without a call per pixel.
    auto shade = [&](float b1, float b2, float invW) {
        return ctx.shading == Shading::kFlat ? flatColorFor(t, ctx)
                                             : isa_scalar::shadeSample(t, ctx, b1, b2, invW);
    };
    // The edge functions stepped exactly along the row.
    int64_t e[3] = {eAtX0[0], eAtX0[1], eAtX0[2]};
    for (int x = x0; x <= x1; ++x, e[0] += step[0], e[1] += step[1], e[2] += step[2]) {
        if ((e[0] | e[1] | e[2]) < 0) continue;
        float k = float(x - t.minX);
        float b1 = b1Row + k * t.stepB1, b2 = b2Row + k * t.stepB2;
        float invW = t.invW[0] + b1 * (t.invW[1] - t.invW[0]) + b2 * (t.invW[2] - t.invW[0]);
        if (ctx.colorOnly) {  // no depth test: submission order decides
            rt.color.at(x, y) = shade(b1, b2, invW);
            ++written;
            continue;
        }
        if (!(invW > rt.depth.at(x, y))) {
            if (rt.visibility.id2.data && invW > rt.visibility.depth2.at(x, y)) {
                rt.visibility.depth2.at(x, y) = invW;
                rt.visibility.id2.at(x, y) = t.id;
            }
            continue;
        }
        if (rt.visibility.id2.data) {
            rt.visibility.depth2.at(x, y) = rt.depth.at(x, y);
            rt.visibility.id2.at(x, y) = rt.id.at(x, y);
        }
        rt.depth.at(x, y) = invW;
        rt.id.at(x, y) = t.id;
        if (rt.color.data) rt.color.at(x, y) = shade(b1, b2, invW);
        ++written;
    }
    return written;
}

// Texel indices floor(f) and floor(f) + 1 wrapped into [0, n) (repeat addressing), given
// fl = floor(f); non-finite values map to texel 0. Large values are reduced in int64 so the
// float->int conversion cannot overflow.
static inline void wrapTexels(float fl, int n, int32_t* i0, int32_t* i1) {
    auto wrap = [n](int64_t i) { return int32_t(((i % n) + n) % n); };
    int64_t i = std::isfinite(fl) ? int64_t(std::clamp(fl, -1e15f, 1e15f)) : 0;
    *i0 = wrap(i);
    *i1 = wrap(i + 1);
}

// Coarse occlusion culling (beyond the P-buffer paper; the hierarchical-z idea of z-buffer
// hardware): per 8x8 pixel block, a lower bound of the depth (1/w, larger is nearer) stored in
// it. Depth only grows during a frame, so a bound taken earlier stays a valid lower bound; blocks
// written since their bound was taken are marked dirty and their bound is refreshed on demand. A
// triangle whose every sample lies at or behind the bound of each block it touches fails the
// strict depth test everywhere there and is skipped before setup; results do not change.
// Tiles are whole blocks, so each block belongs to one thread.
struct DepthBlocks {
    static constexpr int kShift = 3;  // 8x8 pixels
    int blocksX = 0, blocksY = 0;
    std::vector<float> bound;    // per block: <= every depth value in it
    std::vector<uint8_t> dirty;  // per block: written since `bound` was taken

    // Sizes the blocks for a width x height target (keeps them when the size is unchanged).
    void resize(int width, int height);
    // Resets the blocks of the pixel rectangle [x0,x1]x[y0,y1] (whole blocks) to `depth` (the
    // cleared value), or marks them dirty when the depth they hold is unknown.
    void reset(int x0, int y0, int x1, int y1, bool cleared);
    // Marking blocks written and testing them are part of the per-ISA tile kernel
    // (tile_raster.inl: markDirty, blocksHide).
};

// The largest 1/w any covered sample of the snapped triangle (a, b, c) can be given by
// rowBarycentrics' float interpolation (box from triangleBox), or +infinity when no safe bound
// is known. Interpolated 1/w is a convex combination of the vertices' values up to rounding;
// the rounding grows with the barycentric weights at the bounding box corners, which stay below
// 2 * box / area, so slivers (area under 1/64 of their box) get no bound and the rest a 1/64
// relative margin, far above the rounding (< 1e-4 relative with weights below 128).
static inline float nearestInvWBound(const RasterVertex& a, const RasterVertex& b,
                                     const RasterVertex& c, const TriangleBox& box) {
    const int64_t area2 = box.area2 < 0 ? -box.area2 : box.area2;
    if (area2 * 32 < int64_t(box.extentX) * box.extentY)
        return std::numeric_limits<float>::infinity();
    float nearest = std::max({a.invW, b.invW, c.invW});
    return nearest + nearest * (1.0f / 64.0f);
}

}  // namespace plx::raster::detail
