// Stage 1 of the tiled renderer: mesh vertices to clip space, outcodes and snapped screen
// positions, compiled once per ISA (plx_add_isa_kernels). The AVX2 loop (avx2 and avx512 units)
// takes eight vertices at a time with the scalar loop's operations in the scalar loop's order
// (glm's mat4 * vec4 is (m0 x + m1 y) + (m2 z + m3 w); no contraction), so both give the same
// bits and the reference renderer's clipping and snapping agree with it.

#include "pipeline.h"

#if defined(__AVX2__)
#include <immintrin.h>
#define PLX_TRANSFORM_AVX2 1
#endif

namespace plx::raster::detail::PLX_ISA_NS {
namespace {

VertexOut transformOne(const Vec3& p, const Mat4& clipFromWorld, const Viewport& vp) {
    Vec4 c = clipFromWorld * Vec4(p, 1.0f);
    uint32_t code = outcode(c, vp);
    VertexOut v{0, 0, 0.0f, code};
    if (!(code & kOutNeedsClip)) {
        RasterVertex r = snapVertex(c, vp, Vec3(0.0f));
        v.x = r.x;
        v.y = r.y;
        v.invW = r.invW;
    }
    return v;
}

#ifdef PLX_TRANSFORM_AVX2
// Lanes where `mask` is set get `bit`.
inline __m256i bitWhere(__m256 mask, uint32_t bit) {
    return _mm256_and_si256(_mm256_castps_si256(mask), _mm256_set1_epi32(int32_t(bit)));
}

// Eight vertices from p[0..7].
void transformEight(const Vec3* p, const Mat4& m, const Viewport& vp, VertexOut* out) {
    alignas(32) float px[8], py[8], pz[8];
    for (int k = 0; k < 8; ++k) {
        px[k] = p[k].x;
        py[k] = p[k].y;
        pz[k] = p[k].z;
    }
    const __m256 x = _mm256_load_ps(px), y = _mm256_load_ps(py), z = _mm256_load_ps(pz);
    auto component = [&](int r) {  // (m0 x + m1 y) + (m2 z + m3 * 1), as glm evaluates it
        __m256 a0 = _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(m[0][r]), x),
                                  _mm256_mul_ps(_mm256_set1_ps(m[1][r]), y));
        __m256 a1 = _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(m[2][r]), z),
                                  _mm256_set1_ps(m[3][r] * 1.0f));
        return _mm256_add_ps(a0, a1);
    };
    const __m256 cx = component(0), cy = component(1), cz = component(2), cw = component(3);
    const __m256 negW = _mm256_sub_ps(_mm256_setzero_ps(), cw);
    const __m256 absMask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    // outcode(): ordered comparisons are false for NaN, as the scalar ones.
    __m256i code = _mm256_or_si256(bitWhere(_mm256_cmp_ps(cx, negW, _CMP_LT_OQ), kOutLeft),
                                   bitWhere(_mm256_cmp_ps(cx, cw, _CMP_GT_OQ), kOutRight));
    code = _mm256_or_si256(code, bitWhere(_mm256_cmp_ps(cy, negW, _CMP_LT_OQ), kOutBottom));
    code = _mm256_or_si256(code, bitWhere(_mm256_cmp_ps(cy, cw, _CMP_GT_OQ), kOutTop));
    code = _mm256_or_si256(code, bitWhere(_mm256_cmp_ps(cz, negW, _CMP_LT_OQ), kOutNear));
    code = _mm256_or_si256(code, bitWhere(_mm256_cmp_ps(cz, cw, _CMP_GT_OQ), kOutFar));
    __m256 guard =
        _mm256_or_ps(_mm256_cmp_ps(_mm256_and_ps(cx, absMask),
                                   _mm256_mul_ps(_mm256_set1_ps(vp.guardX), cw), _CMP_GT_OQ),
                     _mm256_cmp_ps(_mm256_and_ps(cy, absMask),
                                   _mm256_mul_ps(_mm256_set1_ps(vp.guardY), cw), _CMP_GT_OQ));
    code = _mm256_or_si256(code, bitWhere(guard, kOutGuard));
    __m256 nan = _mm256_or_ps(
        _mm256_or_ps(_mm256_cmp_ps(cw, cw, _CMP_UNORD_Q), _mm256_cmp_ps(cx, cx, _CMP_UNORD_Q)),
        _mm256_or_ps(_mm256_cmp_ps(cy, cy, _CMP_UNORD_Q), _mm256_cmp_ps(cz, cz, _CMP_UNORD_Q)));
    code = _mm256_or_si256(code, bitWhere(nan, kOutFrustum));
    // snapVertex() for the lanes that need no clipping; the others stay zero.
    const __m256i snapped = _mm256_cmpeq_epi32(
        _mm256_and_si256(code, _mm256_set1_epi32(int32_t(kOutNeedsClip))), _mm256_setzero_si256());
    const __m256 invW = _mm256_div_ps(_mm256_set1_ps(1.0f), cw);
    const __m256 halfW = _mm256_set1_ps(vp.halfWidth), halfH = _mm256_set1_ps(vp.halfHeight);
    const __m256 scale = _mm256_set1_ps(float(kSubPixelScale));
    __m256 sx = _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(cx, invW), halfW), halfW);
    __m256 sy = _mm256_sub_ps(halfH, _mm256_mul_ps(_mm256_mul_ps(cy, invW), halfH));
    __m256i ix = _mm256_and_si256(_mm256_cvtps_epi32(_mm256_mul_ps(sx, scale)), snapped);
    __m256i iy = _mm256_and_si256(_mm256_cvtps_epi32(_mm256_mul_ps(sy, scale)), snapped);
    __m256i iw = _mm256_and_si256(_mm256_castps_si256(invW), snapped);
    alignas(32) int32_t ox[8], oy[8], ow[8], oc[8];
    _mm256_store_si256(reinterpret_cast<__m256i*>(ox), ix);
    _mm256_store_si256(reinterpret_cast<__m256i*>(oy), iy);
    _mm256_store_si256(reinterpret_cast<__m256i*>(ow), iw);
    _mm256_store_si256(reinterpret_cast<__m256i*>(oc), code);
    for (int k = 0; k < 8; ++k) {
        float w;
        std::memcpy(&w, &ow[k], 4);
        out[k] = {ox[k], oy[k], w, uint32_t(oc[k])};
    }
}
#endif

}  // namespace

void transformPositions(const Vec3* positions, size_t count, const Mat4& clipFromWorld,
                        const Viewport& vp, VertexOut* out) {
    size_t i = 0;
#ifdef PLX_TRANSFORM_AVX2
    for (; i + 8 <= count; i += 8) transformEight(positions + i, clipFromWorld, vp, out + i);
#endif
    for (; i < count; ++i) out[i] = transformOne(positions[i], clipFromWorld, vp);
}

}  // namespace plx::raster::detail::PLX_ISA_NS
