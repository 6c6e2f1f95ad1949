// The row transform of the warp (row_kernel.h), compiled once per ISA (plx_add_isa_kernels):
// McMillan's equation per source pixel, the splat size and the destination rectangle. The avx2
// unit takes eight pixels per step with the same operations in the same order as the scalar
// path (no fused multiply-adds; -ffp-contract=off), so both give the same bits.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

#if defined(__AVX2__)
#include <immintrin.h>
#endif

#include "row_kernel.h"

namespace plx::warp::detail::PLX_ISA_NS {

namespace {

// max and min with the operand order of _mm256_max_ps / _mm256_min_ps (NaN in `a` gives b).
inline float maxps(float a, float b) {
    return a > b ? a : b;
}
inline float minps(float a, float b) {
    return a < b ? a : b;
}
inline float absf(float v) {
    return std::fabs(v);
}

// One source pixel; the reference the vector loop follows step by step.
inline void transformPixel(const RowInput& in, float tnx, float tny, float tnd, int x,
                           const RowOutput& out, int i) {
    const WarpCoefficients& w = in.w;
    const float delta = in.disparity[x];
    const float fx = float(x);
    const float nx = (tnx + w.a * fx) + w.c * delta;
    const float ny = (tny + w.d * fx) + w.f * delta;
    const float nd = (tnd + w.g * fx) + w.i * delta;
    const float r = 1.0f / nd;
    const float xp = nx * r;
    const float yp = ny * r;
    const float dd = delta * r;
    float hx = 0.5f, hy = 0.5f;
    if (in.splat == RowSplat::kFixed2x2) {
        hx = hy = 1.0f;
    } else if (in.splat == RowSplat::kDerivative) {
        // Disparity derivatives: the smaller one-sided difference (splat.h).
        const float* row = in.disparity;
        float ddx = 0.0f;
        if (x > 0 && x + 1 < in.width) {
            const float back = delta - row[x - 1], fwd = row[x + 1] - delta;
            ddx = absf(fwd) < absf(back) ? fwd : back;
        } else if (x + 1 < in.width) {
            ddx = row[x + 1] - delta;
        } else if (x > 0) {
            ddx = delta - row[x - 1];
        }
        float ddy = 0.0f;
        if (in.above && in.below) {
            const float back = delta - in.above[x], fwd = in.below[x] - delta;
            ddy = absf(fwd) < absf(back) ? fwd : back;
        } else if (in.below) {
            ddy = in.below[x] - delta;
        } else if (in.above) {
            ddy = delta - in.above[x];
        }
        const float cx = w.c - w.i * xp;
        const float cy = w.f - w.i * yp;
        const float sx =
            absf((ddx * cx + (w.a - w.g * xp)) * r) + absf((ddy * cx + (w.b - w.h * xp)) * r);
        const float sy =
            absf((ddx * cy + (w.d - w.g * yp)) * r) + absf((ddy * cy + (w.e - w.h * yp)) * r);
        hx = 0.5f * minps(maxps(sx, 1.0f), in.maxSplat);
        hy = 0.5f * minps(maxps(sy, 1.0f), in.maxSplat);
    }
    // Pixels whose centres lie in [x' - hx, x' + hx): ceil(x' - hx - 0.5) .. ceil(x' + hx - 0.5).
    const float bx0 = minps(maxps(std::ceil((xp - hx) - 0.5f), 0.0f), in.destWidth);
    const float bx1 = minps(maxps(std::ceil((xp + hx) - 0.5f), 0.0f), in.destWidth);
    const float by0 = minps(maxps(std::ceil((yp - hy) - 0.5f), 0.0f), in.destHeight);
    const float by1 = minps(maxps(std::ceil((yp + hy) - 0.5f), 0.0f), in.destHeight);
    const bool valid = nd > 0.0f;
    uint32_t bits;
    std::memcpy(&bits, &dd, 4);
    out.rx0[i] = int32_t(bx0);
    out.rx1[i] = valid ? int32_t(bx1) : int32_t(bx0);
    out.ry0[i] = int32_t(by0);
    out.ry1[i] = int32_t(by1);
    out.key[i] = valid ? bits + 1u : 0u;
}

#if defined(__AVX2__)
inline __m256 abs8(__m256 v) {
    return _mm256_andnot_ps(_mm256_set1_ps(-0.0f), v);
}
// absf(fwd) < absf(back) ? fwd : back
inline __m256 smaller8(__m256 back, __m256 fwd) {
    return _mm256_blendv_ps(back, fwd, _mm256_cmp_ps(abs8(fwd), abs8(back), _CMP_LT_OQ));
}
inline __m256 ceil8(__m256 v) {
    return _mm256_round_ps(v, _MM_FROUND_TO_POS_INF | _MM_FROUND_NO_EXC);
}
inline int32_t minLane(__m256i v) {
    __m128i m = _mm_min_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
    m = _mm_min_epi32(m, _mm_shuffle_epi32(m, _MM_SHUFFLE(1, 0, 3, 2)));
    return _mm_cvtsi128_si32(_mm_min_epi32(m, _mm_shuffle_epi32(m, _MM_SHUFFLE(2, 3, 0, 1))));
}
inline int32_t maxLane(__m256i v) {
    __m128i m = _mm_max_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
    m = _mm_max_epi32(m, _mm_shuffle_epi32(m, _MM_SHUFFLE(1, 0, 3, 2)));
    return _mm_cvtsi128_si32(_mm_max_epi32(m, _mm_shuffle_epi32(m, _MM_SHUFFLE(2, 3, 0, 1))));
}
#endif

}  // namespace

RowReach transformRow(const RowInput& in, const RowOutput& out) {
    // rowTerms (equation.h), spelled out: an inline function from a header, if the compiler
    // kept it out of line here, would be an AVX2 copy the linker might give scalar callers.
    const float fy = float(in.y);
    const RowTerms t{in.w.b * fy + in.w.k, in.w.e * fy + in.w.l, in.w.h * fy + in.w.m};
    // The rows the splats reach, gathered as they are made: a pass over the row afterwards (its
    // loop stayed scalar) took a third of the transform.
    const int32_t none = int32_t(in.destHeight);
    RowReach reach{none, 0};
    const auto pixel = [&](int x) {
        const int i = x - in.x0;
        transformPixel(in, t.nx, t.ny, t.nd, x, out, i);
        if (out.rx0[i] < out.rx1[i]) {
            reach.y0 = std::min(reach.y0, out.ry0[i]);
            reach.y1 = std::max(reach.y1, out.ry1[i]);
        }
    };
    int x = in.x0;
#if defined(__AVX2__)
    // Vector lanes need both row neighbours inside the row (the derivative's differences).
    const int vecBegin = in.x0 > 1 ? in.x0 : 1;
    for (; x < vecBegin && x < in.x1; ++x) pixel(x);
    __m256i reachTop = _mm256_set1_epi32(none), reachBottom = _mm256_setzero_si256();
    const WarpCoefficients& w = in.w;
    const __m256 a = _mm256_set1_ps(w.a), c = _mm256_set1_ps(w.c), d = _mm256_set1_ps(w.d),
                 f = _mm256_set1_ps(w.f), g = _mm256_set1_ps(w.g), ii = _mm256_set1_ps(w.i);
    const __m256 tnx = _mm256_set1_ps(t.nx), tny = _mm256_set1_ps(t.ny), tnd = _mm256_set1_ps(t.nd);
    const __m256 one = _mm256_set1_ps(1.0f), half = _mm256_set1_ps(0.5f),
                 zero = _mm256_setzero_ps();
    const __m256 dw = _mm256_set1_ps(in.destWidth), dh = _mm256_set1_ps(in.destHeight);
    const __m256 cap = _mm256_set1_ps(in.maxSplat);
    const __m256 fixedHalf = _mm256_set1_ps(in.splat == RowSplat::kFixed2x2 ? 1.0f : 0.5f);
    const __m256 b = _mm256_set1_ps(w.b), e = _mm256_set1_ps(w.e), h = _mm256_set1_ps(w.h);
    // x as float, advancing by 8 per step (exact below 2^24).
    __m256 fx = _mm256_add_ps(_mm256_set1_ps(float(x)), _mm256_setr_ps(0, 1, 2, 3, 4, 5, 6, 7));
    const __m256 eight = _mm256_set1_ps(8.0f);
    const int vecEnd = in.x1 < in.width - 1 ? in.x1 : in.width - 1;
    for (; x + 8 <= vecEnd; x += 8, fx = _mm256_add_ps(fx, eight)) {
        const float* row = in.disparity;
        const __m256 delta = _mm256_loadu_ps(row + x);
        const __m256 nx =
            _mm256_add_ps(_mm256_add_ps(tnx, _mm256_mul_ps(a, fx)), _mm256_mul_ps(c, delta));
        const __m256 ny =
            _mm256_add_ps(_mm256_add_ps(tny, _mm256_mul_ps(d, fx)), _mm256_mul_ps(f, delta));
        const __m256 nd =
            _mm256_add_ps(_mm256_add_ps(tnd, _mm256_mul_ps(g, fx)), _mm256_mul_ps(ii, delta));
        const __m256 r = _mm256_div_ps(one, nd);
        const __m256 xp = _mm256_mul_ps(nx, r);
        const __m256 yp = _mm256_mul_ps(ny, r);
        const __m256 dd = _mm256_mul_ps(delta, r);
        __m256 hx = fixedHalf, hy = fixedHalf;
        if (in.splat == RowSplat::kDerivative) {
            const __m256 ddx = smaller8(_mm256_sub_ps(delta, _mm256_loadu_ps(row + x - 1)),
                                        _mm256_sub_ps(_mm256_loadu_ps(row + x + 1), delta));
            __m256 ddy = zero;
            if (in.above && in.below)
                ddy = smaller8(_mm256_sub_ps(delta, _mm256_loadu_ps(in.above + x)),
                               _mm256_sub_ps(_mm256_loadu_ps(in.below + x), delta));
            else if (in.below)
                ddy = _mm256_sub_ps(_mm256_loadu_ps(in.below + x), delta);
            else if (in.above)
                ddy = _mm256_sub_ps(delta, _mm256_loadu_ps(in.above + x));
            const __m256 cx = _mm256_sub_ps(c, _mm256_mul_ps(ii, xp));
            const __m256 cy = _mm256_sub_ps(f, _mm256_mul_ps(ii, yp));
            auto term = [&](__m256 dd1, __m256 cc, __m256 k, __m256 kk, __m256 p) {
                return abs8(_mm256_mul_ps(
                    _mm256_add_ps(_mm256_mul_ps(dd1, cc), _mm256_sub_ps(k, _mm256_mul_ps(kk, p))),
                    r));
            };
            const __m256 sx = _mm256_add_ps(term(ddx, cx, a, g, xp), term(ddy, cx, b, h, xp));
            const __m256 sy = _mm256_add_ps(term(ddx, cy, d, g, yp), term(ddy, cy, e, h, yp));
            hx = _mm256_mul_ps(half, _mm256_min_ps(_mm256_max_ps(sx, one), cap));
            hy = _mm256_mul_ps(half, _mm256_min_ps(_mm256_max_ps(sy, one), cap));
        }
        auto bound = [&](__m256 p, __m256 hsz, bool plus, __m256 limit) {
            const __m256 q = plus ? _mm256_add_ps(p, hsz) : _mm256_sub_ps(p, hsz);
            return _mm256_cvttps_epi32(
                _mm256_min_ps(_mm256_max_ps(ceil8(_mm256_sub_ps(q, half)), zero), limit));
        };
        const __m256i bx0 = bound(xp, hx, false, dw);
        const __m256i bx1 = bound(xp, hx, true, dw);
        const __m256i by0 = bound(yp, hy, false, dh);
        const __m256i by1 = bound(yp, hy, true, dh);
        const __m256i valid = _mm256_castps_si256(_mm256_cmp_ps(nd, zero, _CMP_GT_OQ));
        const __m256i key = _mm256_and_si256(
            valid, _mm256_add_epi32(_mm256_castps_si256(dd), _mm256_set1_epi32(1)));
        const int i = x - in.x0;
        const __m256i rx1 = _mm256_blendv_epi8(bx0, bx1, valid);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.rx0 + i), bx0);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.rx1 + i), rx1);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.ry0 + i), by0);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.ry1 + i), by1);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(out.key + i), key);
        const __m256i live = _mm256_cmpgt_epi32(rx1, bx0);
        reachTop = _mm256_min_epi32(reachTop, _mm256_blendv_epi8(reachTop, by0, live));
        reachBottom = _mm256_max_epi32(reachBottom, _mm256_and_si256(by1, live));
    }
    reach.y0 = std::min(reach.y0, minLane(reachTop));
    reach.y1 = std::max(reach.y1, maxLane(reachBottom));
#endif
    for (; x < in.x1; ++x) pixel(x);
    return reach;
}

}  // namespace plx::warp::detail::PLX_ISA_NS
