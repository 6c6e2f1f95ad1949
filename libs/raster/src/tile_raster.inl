// The tile kernel, compiled once per ISA (plx_add_isa_kernels): the walk over a tile's bins
// (drawTile) and the fast pixel loops. Coverage is exact: integer edge functions with the
// top-left rule. Interpolation follows rowBarycentrics (pipeline.h) in every loop, so depth, IDs
// and colours are bit-identical to reference.cpp.
//
//  - small triangles (both extents under kSimdMaxExtentPx) at most eight pixels wide in the tile:
//    one group of eight per row, everything stepped row by row in int32; flat-shaded ones come
//    straight from the bins (rasterizeNarrowFlat), without the general TriangleSetup;
//  - other small triangles: the bounding box walked eight pixels
//    at a time with AVX2, edge values in int32 lanes;
//  - larger triangles: each row's covered span solved with at most one integer division per
//    edge, then filled eight pixels at a time with no coverage test;
//  - before the box and span walks, the rows of the tile that no edge lets in are cut
//    (trimEmptyRows: a triangle binned by its box may cover only a corner of a tile);
//  - Gouraud and textured samples shaded eight at a time (shadeEight: gathered texels, table
//    decode and encode), bit-identical to shadeSample;
//  - scalar versions of both for the scalar path (and PLX_NO_SIMD builds) and for the second
//    depth layer.
// The 8-wide loops are written with AVX2 intrinsics. The avx512 unit compiles the same source,
// but the renderer takes the avx2 copy on AVX-512 CPUs too (RasterKernels, bins.h).

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include <utility>

#if defined(__SSE2__)
#include <immintrin.h>
#endif
// The per-TU flags decide (isa_kernel.h): the avx2 and avx512 units take the 8-wide loops.
#if defined(__AVX2__)
#define PLX_RASTER_AVX2 1
#endif

#include "bins.h"

namespace plx::raster::detail::PLX_ISA_NS {
namespace {

inline int64_t floorDiv(int64_t a, int64_t b) {  // b > 0
    // The remainder from the quotient, not a % b: with b = -x the compiler otherwise divides
    // twice (by -x for the quotient, by x for the remainder, which C++ makes equal).
    int64_t q = a / b;
    return (a - q * b != 0 && a < 0) ? q - 1 : q;
}

// Narrows [lo, hi] (pixel offsets from the row start) to where e + a * k + bias >= 0.
inline void narrowSpan(int64_t e, int64_t a, int64_t bias, int64_t* lo, int64_t* hi) {
    int64_t c = e + bias;
    if (a == 0) {
        if (c < 0) *hi = -1, *lo = 0;  // empty
    } else if (a > 0) {
        // Rising along the row: inside from ceil(-c / a) on. Most rows of a large triangle lie
        // inside the edge already at lo, and need no division.
        if (c + a * *lo < 0) *lo = std::max(*lo, -floorDiv(c, a));
    } else {
        // Falling: inside up to floor(c / -a); no division when still inside at hi.
        if (c + a * *hi < 0) *hi = std::min(*hi, floorDiv(c, -a));
    }
}

// Edge i runs from vertex i to vertex i+1. Per-pixel steps in x (ax) and y (by), and the
// values at the sample of (x0, y0), plus the top-left bias when `biased`.
struct EdgeSteps {
    int64_t ax[3], by[3], e[3];
    EdgeSteps(const TriangleSetup& t, int x0, int y0, bool biased) {
        const int64_t sx = int64_t(x0) * kSubPixelScale + kSubPixelScale / 2;
        const int64_t sy = int64_t(y0) * kSubPixelScale + kSubPixelScale / 2;
        for (int i = 0; i < 3; ++i) {
            int j = (i + 1) % 3;
            ax[i] = -int64_t(t.y[j] - t.y[i]) * kSubPixelScale;
            by[i] = int64_t(t.x[j] - t.x[i]) * kSubPixelScale;
            e[i] = edgeAt(t.x[i], t.y[i], t.x[j], t.y[j], sx, sy) + (biased ? t.edgeBias[i] : 0);
        }
    }
    void nextRow() {
        for (int i = 0; i < 3; ++i) e[i] += by[i];
    }
};

// Narrows the rows [y0, y1] of the rectangle [x0, x1] x [y0, y1] to those where each edge
// reaches >= 0 (bias included) somewhere in [x0, x1]; the rows cut hold no covered sample. A
// large triangle is binned by its box, so its tiles include corners and whole tiles its edges
// never enter: in a P-buffer second eye of office:280, half the rows its span walks visited were
// empty. Each edge's largest value on a row lies at x1 when it rises along x, else at x0, and
// moves by a fixed step per row, so the rows it allows are narrowed as narrowSpan narrows a row's
// pixels. Returns false when no row is left.
inline bool trimEmptyRows(const TriangleSetup& t, int x0, int x1, int* y0, int* y1) {
    const EdgeSteps edges(t, x0, *y0, true);
    int64_t lo = 0, hi = *y1 - *y0;
    for (int i = 0; i < 3; ++i) {
        const int64_t rowMax = edges.e[i] + (edges.ax[i] > 0 ? edges.ax[i] * (x1 - x0) : 0);
        narrowSpan(rowMax, edges.by[i], 0, &lo, &hi);
    }
    if (lo > hi) return false;
    *y1 = *y0 + int(hi);
    *y0 += int(lo);
    return true;
}

// The edges that can cut a row of the rectangle [x0, x0 + width] x [y0, y0 + height] (edges
// from EdgeSteps at (x0, y0), bias included): those below zero somewhere in it. An edge's value
// is linear, so its smallest lies at a corner; an edge that is >= 0 there never narrows a row.
// Over a tile, most edges of the large triangles that the span walk draws lie wholly outside
// it, and testing only the others (with the whole-group stepping in rasterizeSpansAvx2) took a
// P-buffer second eye of office:280 from 11.33M to 10.35M instructions (callgrind).
struct CuttingEdges {
    int count = 0;
    int index[3] = {};
    CuttingEdges(const EdgeSteps& edges, int width, int height) {
        for (int i = 0; i < 3; ++i) {
            const int64_t lowest = edges.e[i] + std::min<int64_t>(0, edges.ax[i] * width) +
                                   std::min<int64_t>(0, edges.by[i] * height);
            if (lowest < 0) index[count++] = i;
        }
    }
};

// rowBarycentrics' integer numerators (edge 2->0 for b1, 0->1 for b2, at column minX), stepped
// row by row instead of recomputed: the same exact integers, so the same floats.
struct RowWeights {
    int64_t e1, e2, step1, step2;
    RowWeights(const TriangleSetup& t, int y) {
        const int64_t px = int64_t(t.minX) * kSubPixelScale + kSubPixelScale / 2;
        const int64_t py = int64_t(y) * kSubPixelScale + kSubPixelScale / 2;
        e1 = edgeAt(t.x[2], t.y[2], t.x[0], t.y[0], px, py);
        e2 = edgeAt(t.x[0], t.y[0], t.x[1], t.y[1], px, py);
        step1 = int64_t(t.x[0] - t.x[2]) * kSubPixelScale;
        step2 = int64_t(t.x[1] - t.x[0]) * kSubPixelScale;
    }
    void get(const TriangleSetup& t, float* b1Row, float* b2Row) const {
        *b1Row = float(e1) * t.invArea;
        *b2Row = float(e2) * t.invArea;
    }
    void nextRow() {
        e1 += step1;
        e2 += step2;
    }
};

// The colour of one covered sample.
template <Shading kShading>
inline void writeColor(const TriangleSetup& t, const ShadeContext& ctx, float b1, float b2,
                       float invW, const RenderTargets& rt, int x, int y) {
    if constexpr (kShading == Shading::kFlat)
        rt.color.row(y)[x] = flatColorFor(t, ctx);
    else
        rt.color.row(y)[x] = shadeSample(t, ctx, b1, b2, invW);
}

// One covered sample (scalar): depth test, ID, colour, second layer; colour alone without kDepth.
template <Shading kShading, bool kColor, bool kLayer2, bool kDepth = true>
inline void writeSample(const TriangleSetup& t, const ShadeContext& ctx, float b1, float b2,
                        const RenderTargets& rt, int x, int y) {
    float invW = t.invW[0] + b1 * (t.invW[1] - t.invW[0]) + b2 * (t.invW[2] - t.invW[0]);
    if constexpr (!kDepth) {
        writeColor<kShading>(t, ctx, b1, b2, invW, rt, x, y);
        return;
    }
    float& depth = rt.depth.row(y)[x];
    if (!(invW > depth)) {
        if constexpr (kLayer2) {
            if (invW > rt.visibility.depth2.row(y)[x]) {
                rt.visibility.depth2.row(y)[x] = invW;
                rt.visibility.id2.row(y)[x] = t.id;
            }
        }
        return;
    }
    uint32_t& id = rt.id.row(y)[x];
    if constexpr (kLayer2) {
        rt.visibility.depth2.row(y)[x] = depth;
        rt.visibility.id2.row(y)[x] = id;
    }
    depth = invW;
    id = t.id;
    if constexpr (kColor) writeColor<kShading>(t, ctx, b1, b2, invW, rt, x, y);
}

// Scalar: small triangles walk the box testing edge signs, larger ones solve each row's span.
template <Shading kShading, bool kColor, bool kLayer2, bool kDepth = true>
void rasterizeScalar(const TriangleSetup& t, const ShadeContext& ctx, const RenderTargets& rt,
                     int x0, int y0, int x1, int y1, bool spans) {
    EdgeSteps edges(t, x0, y0, true);
    RowWeights weights(t, y0);
    for (int y = y0; y <= y1; ++y, edges.nextRow(), weights.nextRow()) {
        float b1Row, b2Row;
        weights.get(t, &b1Row, &b2Row);
        int64_t lo = 0, hi = x1 - x0;
        if (spans)
            for (int i = 0; i < 3; ++i) narrowSpan(edges.e[i], edges.ax[i], 0, &lo, &hi);
        int64_t e0 = edges.e[0] + edges.ax[0] * lo, e1 = edges.e[1] + edges.ax[1] * lo,
                e2 = edges.e[2] + edges.ax[2] * lo;
        for (int64_t k = lo; k <= hi;
             ++k, e0 += edges.ax[0], e1 += edges.ax[1], e2 += edges.ax[2]) {
            if (!spans && (e0 | e1 | e2) < 0) continue;
            int x = x0 + int(k);
            float dk = float(x - t.minX);
            writeSample<kShading, kColor, kLayer2, kDepth>(t, ctx, b1Row + dk * t.stepB1,
                                                           b2Row + dk * t.stepB2, rt, x, y);
        }
    }
}

#ifdef PLX_RASTER_AVX2
// Triangles spanning fewer pixels than this in x and y take the 8-wide box walk: their edge
// values inside the bounding box stay below 2^31 (differences < 2^14 sub-pixels times steps
// over < 2^14 sub-pixels, twice), so int32 lanes hold them exactly.
constexpr int kSimdMaxExtentPx = 64;
constexpr int32_t kSimdMaxExtent = kSimdMaxExtentPx * kSubPixelScale;  // in 1/256 pixel

// Whether a triangle of these fixed-point extents (TriangleBox's) takes the int32 AVX2 loops.
inline bool withinSimdExtent(int32_t extentX, int32_t extentY) {
    return extentX < kSimdMaxExtent && extentY < kSimdMaxExtent;
}

// Per-triangle constants of the 8-wide loops, loaded once (stores through the target rows could
// alias the setup, so the compiler would otherwise reload them for every eight pixels).
struct EightConstants {
    __m256 w0, dw1, dw2;
    __m256i id;
    explicit EightConstants(const TriangleSetup& t)
        : w0(_mm256_set1_ps(t.invW[0])),
          dw1(_mm256_set1_ps(t.invW[1] - t.invW[0])),
          dw2(_mm256_set1_ps(t.invW[2] - t.invW[0])),
          id(_mm256_set1_epi32(int32_t(t.id))) {}
};

// The three target rows of one row of pixels, stepped row by row (an absent target stays null).
struct TargetRows {
    float* depth;
    uint32_t* id;
    Rgba8* color;
    ptrdiff_t depthStride, idStride, colorStride;
    // depthTargets: false in a colour-only render, whose depth and ID views may be empty (a
    // constant at every call, so the test folds away).
    TargetRows(const RenderTargets& rt, int y, bool depthTargets)
        : depth(depthTargets ? rt.depth.row(y) : nullptr),
          id(depthTargets ? rt.id.row(y) : nullptr),
          color(rt.color.data ? rt.color.row(y) : nullptr),
          depthStride(depthTargets ? rt.depth.strideElems : 0),
          idStride(depthTargets ? rt.id.strideElems : 0),
          colorStride(rt.color.data ? rt.color.strideElems : 0) {}
    void nextRow() {
        depth += depthStride;
        id += idStride;
        color += colorStride;
    }
};

// How storeLanes may write: only the masked lanes (vpmaskmov), by reading, blending and writing
// back all eight (they belong to this thread's tile), or all eight outright (every lane passed).
enum class LaneStore { kMasked, kBlend, kAll };

// Writes the lanes of `value` selected by `mask` to p[0..7]. Masked stores (vpmaskmov) are
// microcoded and slow on some x86 cores, so where all eight pixels belong to this thread's tile
// the row is read, blended and written back instead, or, where every lane passed (the inside
// of large triangles), simply overwritten.
inline void storeLanes(void* p, __m256i mask, __m256i value, LaneStore how) {
    auto* v = reinterpret_cast<__m256i*>(p);
    if (how == LaneStore::kAll)
        _mm256_storeu_si256(v, value);
    else if (how == LaneStore::kBlend)
        _mm256_storeu_si256(v, _mm256_blendv_epi8(_mm256_loadu_si256(v), value, mask));
    else
        _mm256_maskstore_epi32(reinterpret_cast<int*>(p), mask, value);
}

// Gouraud and textured shading of eight samples at once: shadeSample's arithmetic (setup.cpp),
// operation for operation in the same order (the build disables FMA contraction), so every lane
// gets the scalar path's colour to the bit. Texels are fetched with gathers, decoded through the
// 256-entry sRGB table and re-encoded through srgbEncodeTable(); lanes whose bilinear footprint
// wraps around the texture's border get their texel indices from the scalar wrap (rare).
// srgbEncodeTable() widened to 32-bit entries so that gathers never read past its end. A plain
// array: a std::vector here would instantiate library templates shared by name with the other
// ISAs' copies (isa_kernel.h).
struct EncodeTable32 {
    uint32_t entries[kSrgbEncodeEntries + 1];
    EncodeTable32() {
        const uint8_t* bytes = srgbEncodeTable();
        for (int i = 0; i <= kSrgbEncodeEntries; ++i) entries[i] = bytes[i];
    }
};

const uint32_t* encodeTable32() {
    static const EncodeTable32 table;
    return table.entries;
}

// Per-triangle constants of shadeEight.
struct ShadeConstants {
    __m256 invW1, invW2;
    __m256 color[3][3];  // [vertex][channel]
    __m256 uv[3][2];     // [vertex][u, v]
    // Texture LOD (mipmapped textures): the per-triangle terms of shadeSample's derivatives.
    __m256 dInvWdx, dInvWdy, dQdx[2], dQdy[2], baseSize[2];
    const scene::Texture* texture;
    const float* decode;
    const uint32_t* encode;
    // Texel offsets are gathered as int32: levels of 2^31 texels or more shade per lane.
    bool scalar = false;

    void prepare(const TriangleSetup& t) {
        invW1 = _mm256_set1_ps(t.invW[1]);
        invW2 = _mm256_set1_ps(t.invW[2]);
        texture = t.texture;
        decode = srgbDecodeTable();
        encode = encodeTable32();
        scalar = false;
        for (int i = 0; i < 3; ++i) {
            for (int c = 0; c < 3; ++c) color[i][c] = _mm256_set1_ps(t.color[i][c]);
            for (int c = 0; c < 2; ++c) uv[i][c] = _mm256_set1_ps(t.uv[i][c]);
        }
        if (!texture) return;
        scalar = texture->mips[0].pixelCount() > size_t(std::numeric_limits<int32_t>::max());
        if (texture->mips.size() == 1) return;
        // The same expressions as shadeSample's, evaluated once (scalar, same rounding).
        float wx = t.b1dx * (t.invW[1] - t.invW[0]) + t.b2dx * (t.invW[2] - t.invW[0]);
        float wy = t.b1dy * (t.invW[1] - t.invW[0]) + t.b2dy * (t.invW[2] - t.invW[0]);
        Vec2 q0 = t.uv[0] * t.invW[0], q1 = t.uv[1] * t.invW[1], q2 = t.uv[2] * t.invW[2];
        Vec2 qx = t.b1dx * (q1 - q0) + t.b2dx * (q2 - q0);
        Vec2 qy = t.b1dy * (q1 - q0) + t.b2dy * (q2 - q0);
        dInvWdx = _mm256_set1_ps(wx);
        dInvWdy = _mm256_set1_ps(wy);
        for (int c = 0; c < 2; ++c) {
            dQdx[c] = _mm256_set1_ps(qx[c]);
            dQdy[c] = _mm256_set1_ps(qy[c]);
        }
        baseSize[0] = _mm256_set1_ps(float(texture->mips[0].width()));
        baseSize[1] = _mm256_set1_ps(float(texture->mips[0].height()));
    }
};

// a0 * c0 + a1 * c1 + a2 * c2, left to right (glm's order for the scalar Vec3/Vec2 sums).
inline __m256 weighted(__m256 p0, __m256 p1, __m256 p2, __m256 c0, __m256 c1, __m256 c2) {
    return _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(p0, c0), _mm256_mul_ps(p1, c1)),
                         _mm256_mul_ps(p2, c2));
}

// The mip level shadeSample picks in each lane of `active` (0 elsewhere).
inline void mipLevels(const ShadeConstants& s, __m256 u, __m256 v, __m256 w, __m256i active,
                      int32_t level[8]) {
    // rho^2 = max(|dUV/dx * size|^2, |dUV/dy * size|^2), as in shadeSample.
    auto lengthSq = [&](__m256 dInvW, const __m256 dQ[2]) {
        __m256 du = _mm256_mul_ps(_mm256_sub_ps(dQ[0], _mm256_mul_ps(u, dInvW)), w);
        __m256 dv = _mm256_mul_ps(_mm256_sub_ps(dQ[1], _mm256_mul_ps(v, dInvW)), w);
        __m256 x = _mm256_mul_ps(du, s.baseSize[0]), y = _mm256_mul_ps(dv, s.baseSize[1]);
        return _mm256_add_ps(_mm256_mul_ps(x, x), _mm256_mul_ps(y, y));
    };
    __m256 lx = lengthSq(s.dInvWdx, s.dQdx), ly = lengthSq(s.dInvWdy, s.dQdy);
    // std::max(lx, ly) is (lx < ly ? ly : lx); max_ps(ly, lx) is (ly > lx ? ly : lx), which
    // agrees for NaNs too.
    __m256 rho2 = _mm256_max_ps(ly, lx);
    __m256 minified = _mm256_and_ps(_mm256_cmp_ps(rho2, _mm256_set1_ps(1.0f), _CMP_GT_OQ),
                                    _mm256_cmp_ps(rho2, _mm256_set1_ps(INFINITY), _CMP_LT_OQ));
    _mm256_store_si256(reinterpret_cast<__m256i*>(level), _mm256_setzero_si256());
    int bits = _mm256_movemask_ps(_mm256_and_ps(minified, _mm256_castsi256_ps(active)));
    if (!bits) return;
    alignas(32) float r[8];
    _mm256_store_ps(r, rho2);
    const int top = int(s.texture->mips.size()) - 1;
    for (; bits; bits &= bits - 1) {
        int lane = __builtin_ctz(unsigned(bits));
        level[lane] = std::min(int(std::lround(0.5f * std::log2(r[lane]))), top);
    }
}

// Linear RGB of the four texels at element offsets `offset` of `texels`: gather, then decode
// the three channels through the 256-entry table.
inline void decodeTexels(const uint32_t* texels, __m256i offset, const float* decode,
                         __m256 rgb[3]) {
    __m256i c = _mm256_i32gather_epi32(reinterpret_cast<const int*>(texels), offset, 4);
    const __m256i byte = _mm256_set1_epi32(0xff);
    rgb[0] = _mm256_i32gather_ps(decode, _mm256_and_si256(c, byte), 4);
    rgb[1] = _mm256_i32gather_ps(decode, _mm256_and_si256(_mm256_srli_epi32(c, 8), byte), 4);
    rgb[2] = _mm256_i32gather_ps(decode, _mm256_and_si256(_mm256_srli_epi32(c, 16), byte), 4);
}

// sampleBilinear (setup.cpp) of `level` at (u, v) for the lanes of `active`; other lanes are
// left undefined.
inline void sampleBilinearEight(const Image<Rgba8>& level, __m256 u, __m256 v, __m256i active,
                                const float* decode, __m256 out[3]) {
    const int w = level.width(), h = level.height();
    const __m256 half = _mm256_set1_ps(0.5f), one = _mm256_set1_ps(1.0f);
    __m256 fx = _mm256_sub_ps(_mm256_mul_ps(u, _mm256_set1_ps(float(w))), half);
    __m256 fy = _mm256_sub_ps(_mm256_mul_ps(v, _mm256_set1_ps(float(h))), half);
    __m256 flx = _mm256_floor_ps(fx), fly = _mm256_floor_ps(fy);
    __m256 ax = _mm256_sub_ps(fx, flx), ay = _mm256_sub_ps(fy, fly);
    // Lanes whose four texels lie inside the level (sampleBilinear's fast case).
    const __m256 zero = _mm256_setzero_ps();
    __m256 inside = _mm256_and_ps(
        _mm256_and_ps(_mm256_cmp_ps(flx, zero, _CMP_GE_OQ),
                      _mm256_cmp_ps(flx, _mm256_set1_ps(float(w - 1)), _CMP_LT_OQ)),
        _mm256_and_ps(_mm256_cmp_ps(fly, zero, _CMP_GE_OQ),
                      _mm256_cmp_ps(fly, _mm256_set1_ps(float(h - 1)), _CMP_LT_OQ)));
    __m256i x0 = _mm256_and_si256(_mm256_cvttps_epi32(flx), _mm256_castps_si256(inside));
    __m256i y0 = _mm256_and_si256(_mm256_cvttps_epi32(fly), _mm256_castps_si256(inside));
    const __m256i oneI = _mm256_set1_epi32(1);
    __m256i x1 = _mm256_add_epi32(x0, oneI), y1 = _mm256_add_epi32(y0, oneI);
    int wrapped = _mm256_movemask_ps(_mm256_andnot_ps(inside, _mm256_castsi256_ps(active)));
    if (wrapped) {
        alignas(32) int32_t ix0[8], ix1[8], iy0[8], iy1[8];
        alignas(32) float lx[8], ly[8];
        _mm256_store_si256(reinterpret_cast<__m256i*>(ix0), x0);
        _mm256_store_si256(reinterpret_cast<__m256i*>(ix1), x1);
        _mm256_store_si256(reinterpret_cast<__m256i*>(iy0), y0);
        _mm256_store_si256(reinterpret_cast<__m256i*>(iy1), y1);
        _mm256_store_ps(lx, flx);
        _mm256_store_ps(ly, fly);
        for (; wrapped; wrapped &= wrapped - 1) {
            int lane = __builtin_ctz(unsigned(wrapped));
            wrapTexels(lx[lane], w, &ix0[lane], &ix1[lane]);
            wrapTexels(ly[lane], h, &iy0[lane], &iy1[lane]);
        }
        x0 = _mm256_load_si256(reinterpret_cast<const __m256i*>(ix0));
        x1 = _mm256_load_si256(reinterpret_cast<const __m256i*>(ix1));
        y0 = _mm256_load_si256(reinterpret_cast<const __m256i*>(iy0));
        y1 = _mm256_load_si256(reinterpret_cast<const __m256i*>(iy1));
    }
    // Element offsets of the four texels; lanes outside `active` read texel 0.
    const __m256i width = _mm256_set1_epi32(w);
    __m256i row0 = _mm256_and_si256(_mm256_mullo_epi32(y0, width), active);
    __m256i row1 = _mm256_and_si256(_mm256_mullo_epi32(y1, width), active);
    x0 = _mm256_and_si256(x0, active);
    x1 = _mm256_and_si256(x1, active);
    const auto* texels = reinterpret_cast<const uint32_t*>(level.data());
    __m256 t00[3], t01[3], t10[3], t11[3];
    decodeTexels(texels, _mm256_add_epi32(row0, x0), decode, t00);
    decodeTexels(texels, _mm256_add_epi32(row0, x1), decode, t01);
    decodeTexels(texels, _mm256_add_epi32(row1, x0), decode, t10);
    decodeTexels(texels, _mm256_add_epi32(row1, x1), decode, t11);
    __m256 bx = _mm256_sub_ps(one, ax), by = _mm256_sub_ps(one, ay);
    for (int c = 0; c < 3; ++c) {
        __m256 top = _mm256_add_ps(_mm256_mul_ps(t00[c], bx), _mm256_mul_ps(t01[c], ax));
        __m256 bottom = _mm256_add_ps(_mm256_mul_ps(t10[c], bx), _mm256_mul_ps(t11[c], ax));
        out[c] = _mm256_add_ps(_mm256_mul_ps(top, by), _mm256_mul_ps(bottom, ay));
    }
}

// encodeSrgb8 of eight values, in the low byte of each lane.
inline __m256i encodeEight(__m256 linear, const uint32_t* table) {
    const __m256 one = _mm256_set1_ps(1.0f);
    __m256 inRange = _mm256_and_ps(_mm256_cmp_ps(linear, _mm256_setzero_ps(), _CMP_GT_OQ),
                                   _mm256_cmp_ps(linear, one, _CMP_LT_OQ));
    __m256i index = _mm256_cvttps_epi32(_mm256_add_ps(
        _mm256_mul_ps(linear, _mm256_set1_ps(float(kSrgbEncodeEntries))), _mm256_set1_ps(0.5f)));
    index = _mm256_and_si256(index, _mm256_castps_si256(inRange));
    __m256i code = _mm256_i32gather_epi32(reinterpret_cast<const int*>(table), index, 4);
    code = _mm256_and_si256(code, _mm256_castps_si256(inRange));
    // linear >= 1 encodes to 255; NaN and linear <= 0 to 0.
    __m256i saturated = _mm256_castps_si256(_mm256_cmp_ps(linear, one, _CMP_GE_OQ));
    return _mm256_or_si256(code, _mm256_and_si256(saturated, _mm256_set1_epi32(0xff)));
}

// The packed Rgba8 colours shadeSample gives the lanes of `active` (other lanes undefined).
inline __m256i shadeEight(const ShadeConstants& s, __m256 b1, __m256 b2, __m256 invW,
                          __m256i active) {
    const __m256 one = _mm256_set1_ps(1.0f);
    __m256 w = _mm256_div_ps(one, invW);
    __m256 p1 = _mm256_mul_ps(_mm256_mul_ps(b1, s.invW1), w);
    __m256 p2 = _mm256_mul_ps(_mm256_mul_ps(b2, s.invW2), w);
    __m256 p0 = _mm256_sub_ps(_mm256_sub_ps(one, p1), p2);
    __m256 color[3];
    for (int c = 0; c < 3; ++c)
        color[c] = weighted(p0, p1, p2, s.color[0][c], s.color[1][c], s.color[2][c]);
    if (s.texture) {
        __m256 u = weighted(p0, p1, p2, s.uv[0][0], s.uv[1][0], s.uv[2][0]);
        __m256 v = weighted(p0, p1, p2, s.uv[0][1], s.uv[1][1], s.uv[2][1]);
        __m256 texel[3];
        if (s.texture->mips.size() == 1) {
            sampleBilinearEight(s.texture->mips[0], u, v, active, s.decode, texel);
            for (int c = 0; c < 3; ++c) color[c] = _mm256_mul_ps(color[c], texel[c]);
        } else {
            alignas(32) int32_t level[8];
            mipLevels(s, u, v, w, active, level);
            const __m256i levels = _mm256_load_si256(reinterpret_cast<const __m256i*>(level));
            // One pass per distinct level among the lanes (usually one).
            for (int left = _mm256_movemask_ps(_mm256_castsi256_ps(active)); left;) {
                int lod = level[__builtin_ctz(unsigned(left))];
                __m256i same = _mm256_and_si256(
                    active, _mm256_cmpeq_epi32(levels, _mm256_set1_epi32(lod)));
                sampleBilinearEight(s.texture->mips[size_t(lod)], u, v, same, s.decode, texel);
                for (int c = 0; c < 3; ++c)
                    color[c] = _mm256_blendv_ps(color[c], _mm256_mul_ps(color[c], texel[c]),
                                                _mm256_castsi256_ps(same));
                left &= ~_mm256_movemask_ps(_mm256_castsi256_ps(same));
            }
        }
    }
    __m256i r = encodeEight(color[0], s.encode), g = encodeEight(color[1], s.encode),
            b = encodeEight(color[2], s.encode);
    return _mm256_or_si256(_mm256_or_si256(r, _mm256_slli_epi32(g, 8)),
                           _mm256_or_si256(_mm256_slli_epi32(b, 16),
                                           _mm256_set1_epi32(int32_t(0xff000000u))));
}

// The shading constants of a triangle where the loops shade each sample (Gouraud, textured),
// prepared on the first group that shadeEight shades (most triangles of a dense mesh never get
// one); nothing elsewhere.
template <bool kUsed>
struct ShadeFor {
    explicit ShadeFor(const TriangleSetup&) {}
};
template <>
struct ShadeFor<true> {
    const TriangleSetup& triangle;
    mutable ShadeConstants value;
    mutable bool ready = false;
    explicit ShadeFor(const TriangleSetup& t) : triangle(t) {}
    const ShadeConstants& get() const {
        if (!ready) {
            value.prepare(triangle);
            ready = true;
        }
        return value;
    }
};

// Groups with fewer samples to shade than this take shadeSample lane by lane: shadeEight's
// gathers cost the same for one lane as for eight (measured on the pass-2 benchmark, where the
// uniform grid's triangles cover about four pixels each).
constexpr int kMinShadeLanes = 4;

// The flat colour of the triangle in all eight lanes.
inline __m256i flatColorLanes(const TriangleSetup& t, const ShadeContext& ctx) {
    Rgba8 c = flatColorFor(t, ctx);
    int32_t packed;
    std::memcpy(&packed, &c, 4);
    return _mm256_set1_epi32(packed);
}

// Depth test and writes for up to eight pixels starting at x; `covered` selects the lanes and
// `whole` says that all eight pixels lie inside the tile being drawn. `flatLanes`, when given,
// is the flat colour in every lane, taken once by a caller that will surely draw: otherwise it
// is taken from the setup for each group, reloaded after the stores since they might alias it.
template <Shading kShading, bool kColor, bool kDepth = true>
inline void writeEight(const TriangleSetup& t, const ShadeContext& ctx, const EightConstants& k,
                       const ShadeFor<kColor && kShading != Shading::kFlat>& shade,
                       const TargetRows& rows, int x, __m256i covered, __m256 b1, __m256 b2,
                       bool whole, const __m256i* flatLanes = nullptr) {
    __m256 invW = _mm256_add_ps(_mm256_add_ps(k.w0, _mm256_mul_ps(b1, k.dw1)),
                                _mm256_mul_ps(b2, k.dw2));
    __m256i pass = covered;  // without kDepth every covered lane is written
    if constexpr (kDepth) {
        __m256 depth = whole ? _mm256_loadu_ps(rows.depth + x)
                             : _mm256_maskload_ps(rows.depth + x, covered);
        pass = _mm256_and_si256(covered,
                                _mm256_castps_si256(_mm256_cmp_ps(invW, depth, _CMP_GT_OQ)));
        if (_mm256_testz_si256(pass, pass)) return;
    }
    const LaneStore how = !whole ? LaneStore::kMasked
                          : _mm256_movemask_ps(_mm256_castsi256_ps(pass)) == 0xFF
                              ? LaneStore::kAll
                              : LaneStore::kBlend;
    if constexpr (kDepth) {
        storeLanes(rows.depth + x, pass, _mm256_castps_si256(invW), how);
        storeLanes(rows.id + x, pass, k.id, how);
    }
    if constexpr (kColor) {
        if constexpr (kShading == Shading::kFlat) {
            storeLanes(rows.color + x, pass, flatLanes ? *flatLanes : flatColorLanes(t, ctx), how);
        } else {
            int bits = _mm256_movemask_ps(_mm256_castsi256_ps(pass));
            if (__builtin_popcount(unsigned(bits)) >= kMinShadeLanes && !shade.get().scalar) {
                storeLanes(rows.color + x, pass, shadeEight(shade.get(), b1, b2, invW, pass),
                           how);
                return;
            }
            alignas(32) float lb1[8], lb2[8], lw[8];
            _mm256_store_ps(lb1, b1);
            _mm256_store_ps(lb2, b2);
            _mm256_store_ps(lw, invW);
            for (; bits; bits &= bits - 1) {
                int lane = __builtin_ctz(unsigned(bits));
                rows.color[x + lane] = shadeSample(t, ctx, lb1[lane], lb2[lane], lw[lane]);
            }
        }
    }
}

// b1, b2 for the eight pixels whose column offsets from minX are the lanes of dk:
// rowValue + dk * step.
inline void eightBarycentrics(__m256 dk, __m256 b1Row, __m256 b2Row, __m256 step1, __m256 step2,
                              __m256* b1, __m256* b2) {
    *b1 = _mm256_add_ps(b1Row, _mm256_mul_ps(dk, step1));
    *b2 = _mm256_add_ps(b2Row, _mm256_mul_ps(dk, step2));
}

// The same for the pixels x .. x+7 of a row, dx = x - minX: dk = float(dx + lane).
inline void eightBarycentrics(int dx, __m256 b1Row, __m256 b2Row, __m256 step1, __m256 step2,
                              __m256* b1, __m256* b2) {
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    __m256 dk = _mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_set1_epi32(dx), lane));
    eightBarycentrics(dk, b1Row, b2Row, step1, step2, b1, b2);
}

// Lanes whose pixel x + lane is at most x1.
inline __m256i lanesUpTo(int x, int x1) {
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    return _mm256_cmpgt_epi32(_mm256_set1_epi32(x1 - x + 1), lane);
}

// The lanes of `allowed` whose three (biased) edge values are all >= 0: the covered samples.
inline __m256i insideLanes(const __m256i e[3], __m256i allowed) {
    __m256i sign = _mm256_srai_epi32(_mm256_or_si256(_mm256_or_si256(e[0], e[1]), e[2]), 31);
    return _mm256_andnot_si256(sign, allowed);
}

template <Shading kShading, bool kColor, bool kDepth = true>
void rasterizeBoxAvx2(const TriangleSetup& t, const ShadeContext& ctx, const RenderTargets& rt,
                      int x0, int y0, int x1, int y1, int limitX) {
    EdgeSteps edges(t, x0, y0, true);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    __m256i laneOffset[3], step8[3];
    for (int i = 0; i < 3; ++i) {
        laneOffset[i] = _mm256_mullo_epi32(lane, _mm256_set1_epi32(int32_t(edges.ax[i])));
        step8[i] = _mm256_set1_epi32(int32_t(8 * edges.ax[i]));
    }
    const EightConstants k(t);
    const ShadeFor<kColor && kShading != Shading::kFlat> shade(t);
    const __m256 step1 = _mm256_set1_ps(t.stepB1), step2 = _mm256_set1_ps(t.stepB2);
    const int minX = t.minX;
    RowWeights weights(t, y0);
    TargetRows rows(rt, y0, kDepth);
    for (int y = y0; y <= y1; ++y, edges.nextRow(), weights.nextRow(), rows.nextRow()) {
        float b1Row, b2Row;
        weights.get(t, &b1Row, &b2Row);
        const __m256 b1RowV = _mm256_set1_ps(b1Row), b2RowV = _mm256_set1_ps(b2Row);
        __m256i e[3];
        for (int i = 0; i < 3; ++i)
            e[i] = _mm256_add_epi32(_mm256_set1_epi32(int32_t(edges.e[i])), laneOffset[i]);
        for (int x = x0; x <= x1; x += 8) {
            __m256i covered = insideLanes(e, lanesUpTo(x, x1));
            if (!_mm256_testz_si256(covered, covered)) {
                __m256 b1, b2;
                eightBarycentrics(x - minX, b1RowV, b2RowV, step1, step2, &b1, &b2);
                writeEight<kShading, kColor, kDepth>(t, ctx, k, shade, rows, x, covered, b1,
                                                     b2, x + 7 <= limitX);
            }
            for (int i = 0; i < 3; ++i) e[i] = _mm256_add_epi32(e[i], step8[i]);
        }
    }
}

// The int32 edge setup of the narrow walks. Under kSimdMaxExtentPx pixels of extent, with the
// samples inside the triangle's box (or at most seven pixels past it), every edge value is
// below 2^30, so these are the general path's exact int64 values in int32: lane k of e[i] is
// edge i (vertex i to i+1, top-left bias included) at pixel (x0 + k, y0), and w1, w2 the
// unbiased numerators of rowBarycentrics' b1 and b2 at (minX, y0).
struct NarrowEdges {
    __m256i e[3], stepY[3];
    int32_t w1, w2, stepW1, stepW2;  // stepped by a row
    int32_t ax1, ax2;                // numerator steps of b1 and b2 along a row

    NarrowEdges(const int32_t X[3], const int32_t Y[3], int x0, int y0, int minX) {
        const int32_t sx = x0 * kSubPixelScale + kSubPixelScale / 2;
        const int32_t sy = y0 * kSubPixelScale + kSubPixelScale / 2;
        const int32_t sxMin = minX * kSubPixelScale + kSubPixelScale / 2;
        const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        int32_t rowE[3], ax[3], by[3];
        for (int i = 0; i < 3; ++i) {
            const int j = i == 2 ? 0 : i + 1;
            const int32_t dx = X[j] - X[i], dy = Y[j] - Y[i];
            const int32_t bias = topLeftBias(dx, dy);
            ax[i] = -dy * kSubPixelScale;
            by[i] = dx * kSubPixelScale;
            rowE[i] = dx * (sy - Y[i]) - dy * (sxMin - X[i]);
            const int32_t atSample = dx * (sy - Y[i]) - dy * (sx - X[i]) + bias;
            e[i] = _mm256_add_epi32(_mm256_set1_epi32(atSample),
                                    _mm256_mullo_epi32(lane, _mm256_set1_epi32(ax[i])));
            stepY[i] = _mm256_set1_epi32(by[i]);
        }
        // b1 from edge 2 -> 0, b2 from edge 0 -> 1 (rowBarycentrics).
        w1 = rowE[2], w2 = rowE[0];
        stepW1 = by[2], stepW2 = by[0];
        ax1 = ax[2], ax2 = ax[0];
    }
};

// Triangles whose part in the tile is at most eight pixels wide (most triangles of dense
// meshes): one group of eight per row, so the edge values, the barycentric numerators and the
// lane offsets are set up once and stepped row by row, with no loop across the row. The
// barycentric expression is eightBarycentrics' (rowValue + dk * step, dk fixed for the column),
// so results stay bit-identical to the other paths. invArea, stepB1, stepB2: TriangleSetup's.
template <Shading kShading, bool kColor, bool kDepth = true>
[[gnu::always_inline]] inline void walkNarrowAvx2(const TriangleSetup& t, const ShadeContext& ctx,
                                                 const RenderTargets& rt, NarrowEdges& edges,
                                                 float invArea, float stepB1, float stepB2,
                                                 int minX, int x0, int y0, int x1, int y1,
                                                 int limitX) {
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    const __m256i inRect = lanesUpTo(x0, x1);
    const EightConstants k(t);
    const ShadeFor<kColor && kShading != Shading::kFlat> shade(t);
    const __m256 dk = _mm256_cvtepi32_ps(_mm256_add_epi32(_mm256_set1_epi32(x0 - minX), lane));
    const __m256 offset1 = _mm256_mul_ps(dk, _mm256_set1_ps(stepB1));
    const __m256 offset2 = _mm256_mul_ps(dk, _mm256_set1_ps(stepB2));
    const bool whole = x0 + 7 <= limitX;
    TargetRows rows(rt, y0, kDepth);
    for (int y = y0; y <= y1;
         ++y, edges.w1 += edges.stepW1, edges.w2 += edges.stepW2, rows.nextRow()) {
        __m256i covered = insideLanes(edges.e, inRect);
        if (!_mm256_testz_si256(covered, covered)) {
            __m256 b1 = _mm256_add_ps(_mm256_set1_ps(float(edges.w1) * invArea), offset1);
            __m256 b2 = _mm256_add_ps(_mm256_set1_ps(float(edges.w2) * invArea), offset2);
            writeEight<kShading, kColor, kDepth>(t, ctx, k, shade, rows, x0, covered, b1, b2,
                                                 whole);
        }
        for (int i = 0; i < 3; ++i) edges.e[i] = _mm256_add_epi32(edges.e[i], edges.stepY[i]);
    }
}

template <Shading kShading, bool kColor, bool kDepth = true>
void rasterizeNarrowAvx2(const TriangleSetup& t, const ShadeContext& ctx, const RenderTargets& rt,
                         int x0, int y0, int x1, int y1, int limitX) {
    NarrowEdges edges(t.x, t.y, x0, y0, t.minX);
    walkNarrowAvx2<kShading, kColor, kDepth>(t, ctx, rt, edges, t.invArea, t.stepB1, t.stepB2,
                                             t.minX, x0, y0, x1, y1, limitX);
}

// rasterizeNarrowAvx2 for a flat-shaded triangle straight from the bins, oriented (positive
// area2) but with no TriangleSetup geometry: most triangles of dense meshes cover a few pixels,
// and for them the general setup cost more than their pixels (callgrind, x16 helmet: about 900
// instructions per triangle from the bins to its last pixel). The values are setupTriangleInBox's.
template <bool kColor>
void rasterizeNarrowFlatAvx2(const RasterVertex* v[3], int64_t area2, int minX, TriangleSetup& t,
                             const ShadeContext& ctx, const RenderTargets& rt, int x0, int y0,
                             int x1, int y1, int limitX) {
    for (int i = 0; i < 3; ++i) {
        t.x[i] = v[i]->x;
        t.y[i] = v[i]->y;
        t.invW[i] = v[i]->invW;
    }
    NarrowEdges edges(t.x, t.y, x0, y0, minX);
    const float invArea = 1.0f / float(area2);
    walkNarrowAvx2<Shading::kFlat, kColor>(t, ctx, rt, edges, invArea,
                                           float(edges.ax1) * invArea, float(edges.ax2) * invArea,
                                           minX, x0, y0, x1, y1, limitX);
}

template <Shading kShading, bool kColor, bool kDepth = true>
void rasterizeSpansAvx2(const TriangleSetup& t, const ShadeContext& ctx, const RenderTargets& rt,
                        int x0, int y0, int x1, int y1, int limitX) {
    EdgeSteps edges(t, x0, y0, true);
    const CuttingEdges cutting(edges, x1 - x0, y1 - y0);
    const EightConstants k(t);
    const ShadeFor<kColor && kShading != Shading::kFlat> shade(t);
    const __m256 step1 = _mm256_set1_ps(t.stepB1), step2 = _mm256_set1_ps(t.stepB2);
    const __m256 laneOffsets = _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7), eight = _mm256_set1_ps(8);
    const __m256i allLanes = _mm256_set1_epi32(-1);
    // A triangle that reaches the span walk is large and nearly always draws in this tile (the
    // rows it cannot cover were trimmed), so its colour is taken here once: 3 instructions less
    // per group (9.90M -> 9.71M in a P-buffer second eye of office:280, callgrind).
    const __m256i flat =
        kColor && kShading == Shading::kFlat ? flatColorLanes(t, ctx) : _mm256_setzero_si256();
    const int minX = t.minX;
    RowWeights weights(t, y0);
    TargetRows rows(rt, y0, kDepth);
    for (int y = y0; y <= y1; ++y, edges.nextRow(), weights.nextRow(), rows.nextRow()) {
        int64_t lo = 0, hi = x1 - x0;
        for (int c = 0; c < cutting.count; ++c) {
            const int i = cutting.index[c];
            narrowSpan(edges.e[i], edges.ax[i], 0, &lo, &hi);
        }
        if (lo > hi) continue;
        float b1Row, b2Row;
        weights.get(t, &b1Row, &b2Row);
        const __m256 b1RowV = _mm256_set1_ps(b1Row), b2RowV = _mm256_set1_ps(b2Row);
        const int last = x0 + int(hi);
        int x = x0 + int(lo);
        // The lanes' column offsets x + lane - minX stepped by 8: whole numbers below 2^24, so
        // float(x - minX) + lane is exact and equal to eightBarycentrics' float(x + lane - minX).
        __m256 dk = _mm256_add_ps(_mm256_set1_ps(float(x - minX)), laneOffsets);
        __m256 b1, b2;
        // Whole groups: every lane covered, all eight pixels in the tile (x + 7 <= last <= x1).
        for (; x + 7 <= last; x += 8, dk = _mm256_add_ps(dk, eight)) {
            eightBarycentrics(dk, b1RowV, b2RowV, step1, step2, &b1, &b2);
            writeEight<kShading, kColor, kDepth>(t, ctx, k, shade, rows, x, allLanes, b1, b2, true,
                                                 &flat);
        }
        if (x > last) continue;
        eightBarycentrics(dk, b1RowV, b2RowV, step1, step2, &b1, &b2);
        writeEight<kShading, kColor, kDepth>(t, ctx, k, shade, rows, x, lanesUpTo(x, last), b1, b2,
                                             x + 7 <= limitX, &flat);
    }
}
#endif

}  // namespace

namespace {

// The minimum depth over the 8x8 block at (px0, py0), clipped to the image.
float blockMinimum(const ImageView<float>& depth, int px0, int py0) {
    int px1 = std::min(px0 + 8, depth.width), py1 = std::min(py0 + 8, depth.height);
#ifdef PLX_RASTER_AVX2
    if (px1 - px0 == 8) {
        __m256 m = _mm256_loadu_ps(depth.row(py0) + px0);
        for (int y = py0 + 1; y < py1; ++y)
            m = _mm256_min_ps(m, _mm256_loadu_ps(depth.row(y) + px0));
        __m128 h = _mm_min_ps(_mm256_castps256_ps128(m), _mm256_extractf128_ps(m, 1));
        h = _mm_min_ps(h, _mm_movehl_ps(h, h));
        h = _mm_min_ss(h, _mm_shuffle_ps(h, h, 1));
        return _mm_cvtss_f32(h);
    }
#endif
    float m = std::numeric_limits<float>::infinity();
    for (int y = py0; y < py1; ++y) {
        const float* d = depth.row(y);
        for (int x = px0; x < px1; ++x) m = std::min(m, d[x]);
    }
    return m;
}


// Marks the blocks of the pixel rectangle [x0,x1]x[y0,y1] as possibly written.
void markDirty(DepthBlocks& blocks, int x0, int y0, int x1, int y1) {
    constexpr int kShift = DepthBlocks::kShift;
    const int bx0 = x0 >> kShift, bx1 = x1 >> kShift;
    for (int by = y0 >> kShift; by <= y1 >> kShift; ++by) {
        uint8_t* row = blocks.dirty.data() + size_t(by) * size_t(blocks.blocksX);
        if (bx1 - bx0 <= 1) {
            // One or two blocks, most triangles of dense meshes: two plain stores (the fill below
            // becomes a call to memset).
            row[bx0] = 1;
            row[bx1] = 1;
        } else {
            std::fill(row + bx0, row + bx1 + 1, uint8_t(1));
        }
    }
}

// True when a triangle whose samples all have 1/w <= `nearest` is hidden at every pixel of
// [x0,x1]x[y0,y1] (refreshes the dirty blocks it reads from `depth`).
bool blocksHide(DepthBlocks& blocks, int x0, int y0, int x1, int y1, float nearest,
                const ImageView<float>& depth) {
    constexpr int kShift = DepthBlocks::kShift;
    for (int by = y0 >> kShift; by <= y1 >> kShift; ++by) {
        size_t row = size_t(by) * size_t(blocks.blocksX);
        for (int bx = x0 >> kShift; bx <= x1 >> kShift; ++bx) {
            float& b = blocks.bound[row + size_t(bx)];
            if (nearest <= b) continue;
            if (!blocks.dirty[row + size_t(bx)]) return false;
            b = blockMinimum(depth, bx << kShift, by << kShift);
            blocks.dirty[row + size_t(bx)] = 0;
            if (!(nearest <= b)) return false;
        }
    }
    return true;
}


// Colour-only triangles (checkRenderRequest: a colour target, no second layer) take their own
// function: instantiated inside rasterizeTriangle, their walks pushed the depth-tested ones out
// of the inliner's budget (5% to 10% more tile-stage instructions on office:64 and the x16
// helmet, callgrind). The walk choice repeats rasterizeTriangle's for the same reason: shared
// through a function template it still cost 2% to 3%.
[[gnu::noinline]] void rasterizeColorOnly(const TriangleSetup& t, const ShadeContext& ctx,
                                          const RenderTargets& rt, int x0, int y0, int x1, int y1,
                                          [[maybe_unused]] int limitX, [[maybe_unused]] bool small,
                                          [[maybe_unused]] bool spans) {
    auto run = [&]<Shading kS>() {
#ifdef PLX_RASTER_AVX2
        if (small && x1 - x0 < 8)
            rasterizeNarrowAvx2<kS, true, false>(t, ctx, rt, x0, y0, x1, y1, limitX);
        else if (small)
            rasterizeBoxAvx2<kS, true, false>(t, ctx, rt, x0, y0, x1, y1, limitX);
        else
            rasterizeSpansAvx2<kS, true, false>(t, ctx, rt, x0, y0, x1, y1, limitX);
#else
        rasterizeScalar<kS, true, false, false>(t, ctx, rt, x0, y0, x1, y1, spans);
#endif
    };
    if (ctx.shading == Shading::kFlat)
        run.template operator()<Shading::kFlat>();
    else
        run.template operator()<Shading::kGouraud>();
}


bool narrowFlatApplies(const ShadeContext& ctx, const RenderTargets& rt) {
#ifdef PLX_RASTER_AVX2
    return ctx.shading == Shading::kFlat && !ctx.colorOnly && !rt.visibility.id2.data;
#else
    (void)ctx, (void)rt;
    return false;
#endif
}

bool rasterizeNarrowFlat(const RasterVertex vin[3], const TriangleBox& box, TriangleSetup& t,
                         const ShadeContext& ctx, const RenderTargets& rt, int x0, int y0, int x1,
                         int y1, DepthBlocks* blocks) {
#ifdef PLX_RASTER_AVX2
    const int limitX = x1;
    x0 = std::max(x0, box.minX);
    x1 = std::min(x1, box.maxX);
    if (x1 - x0 >= 8) return false;
    if (!withinSimdExtent(box.extentX, box.extentY)) return false;
    y0 = std::max(y0, box.minY);
    y1 = std::min(y1, box.maxY);
    if (x0 > x1 || y0 > y1) return true;
    if (blocks) markDirty(*blocks, x0, y0, x1, y1);
    const RasterVertex* v[3];
    const int64_t area2 = orientPositive(vin, box.area2, v);
    if (rt.color.data)
        rasterizeNarrowFlatAvx2<true>(v, area2, box.minX, t, ctx, rt, x0, y0, x1, y1, limitX);
    else
        rasterizeNarrowFlatAvx2<false>(v, area2, box.minX, t, ctx, rt, x0, y0, x1, y1, limitX);
    return true;
#else
    (void)vin, (void)box, (void)t, (void)ctx, (void)rt, (void)x0, (void)y0, (void)x1, (void)y1,
        (void)blocks;
    return false;
#endif
}

// Decides, per tile, whether the occlusion test is worth its cost: once it has hidden fewer than
// one in kMinHitRatio of the tile's triangles (a dense mesh whose triangles are in front as they
// come, say) it only probes every kProbeStride-th triangle, so such tiles pay a sixteenth of the
// test, and resumes testing all if the probes start hitting. Only the cost changes, never the
// image. Measured (callgrind, one 1280x720 frame): the subdivided helmet 347M -> 315M
// instructions, office:64 304M -> 308M.
class OcclusionProbe {
public:
    bool shouldTest() {
        if (mTests < kWarmup || mHits * kMinHitRatio >= mTests) return true;
        return ++mSkipped % kProbeStride == 0;
    }
    void record(bool hit) {
        ++mTests;
        mHits += hit ? 1 : 0;
    }

private:
    static constexpr uint32_t kWarmup = 32, kMinHitRatio = 16, kProbeStride = 16;
    uint32_t mTests = 0, mHits = 0, mSkipped = 0;
};

// Rectangles of fewer rows than this are walked whole, since few rows leave little to trim.
// Trimming every rectangle instead changed the instruction counts by under 0.2% (callgrind,
// office:280 stereo pair at 640x480: the full pair 0.15% more, the P-buffer second eye 0.16%
// fewer).
constexpr int kMinTrimmedRows = 4;

void rasterizeTriangle(const TriangleSetup& t, const ShadeContext& ctx, const RenderTargets& rt,
                       int x0, int y0, int x1, int y1, DepthBlocks* blocks) {
    // The caller's rectangle is ours to write, past the triangle too.
    [[maybe_unused]] const int limitX = x1;
    x0 = std::max(x0, t.minX);
    y0 = std::max(y0, t.minY);
    x1 = std::min(x1, t.maxX);
    y1 = std::min(y1, t.maxY);
    if (x0 > x1 || y0 > y1) return;
    if (y1 - y0 >= kMinTrimmedRows && !trimEmptyRows(t, x0, x1, &y0, &y1)) return;
    if (blocks) markDirty(*blocks, x0, y0, x1, y1);
    // Rows of up to kBoxWidth pixels are tested pixel by pixel; longer rows solve their span
    // (a division per edge that crosses the row) so large triangles touch only covered samples.
    constexpr int kBoxWidth = 24;
    bool spans = x1 - x0 >= kBoxWidth;
    bool color = rt.color.data != nullptr;
    bool flat = ctx.shading == Shading::kFlat;
    bool small = false;
#ifdef PLX_RASTER_AVX2
    small = withinSimdExtent(t.extentX, t.extentY);
#endif
    if (ctx.colorOnly) return rasterizeColorOnly(t, ctx, rt, x0, y0, x1, y1, limitX, small, spans);
    auto run = [&]<Shading kS, bool kC, bool kL2>() {
#ifdef PLX_RASTER_AVX2
        if constexpr (!kL2) {
            if (small && x1 - x0 < 8)
                rasterizeNarrowAvx2<kS, kC>(t, ctx, rt, x0, y0, x1, y1, limitX);
            else if (small)
                rasterizeBoxAvx2<kS, kC>(t, ctx, rt, x0, y0, x1, y1, limitX);
            else
                rasterizeSpansAvx2<kS, kC>(t, ctx, rt, x0, y0, x1, y1, limitX);
            return;
        }
#endif
        rasterizeScalar<kS, kC, kL2>(t, ctx, rt, x0, y0, x1, y1, spans);
    };
    if (rt.visibility.id2.data) {
        if (!color) run.template operator()<Shading::kFlat, false, true>();
        else if (flat) run.template operator()<Shading::kFlat, true, true>();
        else run.template operator()<Shading::kGouraud, true, true>();
        return;
    }
    if (flat && color) run.template operator()<Shading::kFlat, true, false>();
    else if (flat) run.template operator()<Shading::kFlat, false, false>();
    else if (color) run.template operator()<Shading::kGouraud, true, false>();
    else run.template operator()<Shading::kGouraud, false, false>();
}

// True when the triangle's part in the tile [x0,x1]x[y0,y1] lies behind what the tile's blocks
// already hold (or covers no sample there), so drawing it would change nothing.
bool hidden(DepthBlocks& blocks, const RasterVertex v[3], const TriangleBox& box, int x0, int y0,
            int x1, int y1, const ImageView<float>& depth) {
    int minX = std::max(box.minX, x0), minY = std::max(box.minY, y0);
    int maxX = std::min(box.maxX, x1), maxY = std::min(box.maxY, y1);
    if (minX > maxX || minY > maxY) return true;
    return blocksHide(blocks, minX, minY, maxX, maxY, nearestInvWBound(v[0], v[1], v[2], box),
                      depth);
}

void clearTile(const RenderTargets& rt, int x0, int y0, int x1, int y1, uint32_t clearWord,
               bool depthAndIds) {
    for (int y = y0; y <= y1; ++y) {
        if (depthAndIds) {
            std::fill(rt.depth.row(y) + x0, rt.depth.row(y) + x1 + 1, 0.0f);
            std::fill(rt.id.row(y) + x0, rt.id.row(y) + x1 + 1, 0u);
        }
        if (rt.color.data)  // as 32-bit words, which the compiler fills several at a time
            std::fill_n(reinterpret_cast<uint32_t*>(rt.color.row(y) + x0), x1 - x0 + 1,
                        clearWord);
        const VisibilityOutputs& layer2 = rt.visibility;
        if (layer2.id2.data) {
            std::fill(layer2.depth2.row(y) + x0, layer2.depth2.row(y) + x1 + 1, 0.0f);
            std::fill(layer2.id2.row(y) + x0, layer2.id2.row(y) + x1 + 1, 0u);
        }
    }
}

// Copies n 32-bit words to a target row with non-temporal stores where the row allows, and
// leaves `clearWord` in the source words. Non-temporal: the finished tile is not read again by
// this thread, so its lines go out without first being read in (a normal store reads each line
// of the cold target before writing it). The clear: the next tile drawn in the same tile memory
// starts from the clear values, and writing them here, while the words are in the first-level
// cache, replaced a separate clear of the whole tile (memset into lines the tile had pushed out
// to the second level) before each tile.
// 16 bytes a store: 32-byte streaming stores halve this loop's instructions but ran the P-buffer
// second eye slower on AMD EPYC (docs/raster-performance.md, tried and dropped).
void streamRowAndClear(uint32_t* dst, uint32_t* src, int n, uint32_t clearWord) {
    int i = 0;
#if defined(__SSE2__)
    for (; i < n && (reinterpret_cast<uintptr_t>(dst + i) & 15); ++i)
        dst[i] = std::exchange(src[i], clearWord);
    const __m128i clear = _mm_set1_epi32(int32_t(clearWord));
    // Four streaming stores a step (a tile row is 128 words): the loop's control is shared by
    // more of them, 11 instructions per 8 words -> 13 per 16 (callgrind).
    for (; i + 16 <= n; i += 16) {
        auto* from = reinterpret_cast<__m128i*>(src + i);
        auto* to = reinterpret_cast<__m128i*>(dst + i);
        for (int k = 0; k < 4; ++k) _mm_stream_si128(to + k, _mm_loadu_si128(from + k));
#if defined(__AVX__)
        const __m256i clear8 = _mm256_set1_epi32(int32_t(clearWord));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(from), clear8);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(from + 2), clear8);
#else
        for (int k = 0; k < 4; ++k) _mm_storeu_si128(from + k, clear);
#endif
    }
    for (; i + 4 <= n; i += 4) {
        auto* from = reinterpret_cast<__m128i*>(src + i);
        _mm_stream_si128(reinterpret_cast<__m128i*>(dst + i), _mm_loadu_si128(from));
        _mm_storeu_si128(from, clear);
    }
#endif
    for (; i < n; ++i) dst[i] = std::exchange(src[i], clearWord);
}

}  // namespace

uint64_t drawTile(const TileJob& job) {
    const int x0 = job.x0, y0 = job.y0, x1 = job.x1, y1 = job.y1;
    const ShadeContext& ctx = *job.ctx;
    const RenderTargets& rt = job.rt;
    if (job.clear) clearTile(rt, x0, y0, x1, y1, job.clearWord, !ctx.colorOnly);
    DepthBlocks* occlusion = job.occlusion;
    uint64_t occluded = 0;
    OcclusionProbe probe;
    TriangleSetup setup;
    const bool narrowFlat = narrowFlatApplies(ctx, rt);
    for (size_t c = 0; c < job.chunkCount; ++c) {
        const Chunk& chunk = job.chunks[c];
        for (const BinnedTri& tri : chunk.bins[job.tile]) {
            RasterVertex v[3];
            for (int k = 0; k < 3; ++k) {
                v[k].x = tri.x[k];
                v[k].y = tri.y[k];
                v[k].invW = tri.invW[k];
            }
            TriangleBox box;
            if (!triangleBox(v[0], v[1], v[2], *job.vp, ctx.cullBackFaces, &box)) continue;
            if (occlusion && probe.shouldTest()) {
                bool hit = hidden(*occlusion, v, box, x0, y0, x1, y1, rt.depth);
                probe.record(hit);
                if (hit) {
                    ++occluded;
                    continue;
                }
            }
            size_t mesh = chunk.mesh;
            uint32_t localTri = tri.ref;
            const Materialised* m = nullptr;
            if (tri.ref & kMaterialisedBit) {
                m = &chunk.materialised[tri.ref & ~kMaterialisedBit];
                mesh = m->mesh;
                localTri = m->localTri;
                for (int k = 0; k < 3; ++k) v[k].bary = m->bary[k];
            } else if (ctx.shading != Shading::kFlat) {  // flat shading reads no weights
                for (int k = 0; k < 3; ++k) v[k].bary = Vec3(k == 0, k == 1, k == 2);
            }
            setTriangleIdentity(*job.scene, mesh, localTri, &setup);
            // A materialised triangle's flat colour was taken at binning.
            if (m && ctx.shading == Shading::kFlat) {
                setup.flatColor = m->flatColor;
                setup.flatReady = true;
            }
            if (narrowFlat &&
                rasterizeNarrowFlat(v, box, setup, ctx, rt, x0, y0, x1, y1, occlusion))
                continue;
            setupTriangleInBox(*job.scene, mesh, localTri, v, box, ctx, &setup);
            rasterizeTriangle(setup, ctx, rt, x0, y0, x1, y1, occlusion);
        }
    }
    return occluded;
}

void resolveTileMemory(const RenderTargets& tile, const RenderTargets& frame, int x0, int y0,
                       int x1, int y1, uint32_t colorWord) {
    const int n = x1 - x0 + 1;
    for (int y = y0; y <= y1; ++y) {
        if (frame.depth.data)
            streamRowAndClear(reinterpret_cast<uint32_t*>(frame.depth.row(y) + x0),
                              reinterpret_cast<uint32_t*>(tile.depth.row(y) + x0), n, 0);
        else
            std::fill_n(tile.depth.row(y) + x0, n, 0.0f);
        if (frame.id.data)
            streamRowAndClear(frame.id.row(y) + x0, tile.id.row(y) + x0, n, 0);
        else
            std::fill_n(tile.id.row(y) + x0, n, 0u);
        if (frame.color.data)
            streamRowAndClear(reinterpret_cast<uint32_t*>(frame.color.row(y) + x0),
                              reinterpret_cast<uint32_t*>(tile.color.row(y) + x0), n, colorWord);
    }
#if defined(__SSE2__)
    _mm_sfence();  // streaming stores are weakly ordered: complete them before the join
#endif
}

}  // namespace plx::raster::detail::PLX_ISA_NS
