#pragma once
// Private: the level walker of the modelled coder (docs/ptm-format.md, "Level groups"). Group
// k >= 1 is coded block row by block row, each row component by component, as runs: p00 of the
// row's full blocks, then p10, then p01, then eps. A run's contexts depend only on the previous
// block row, the lower level and the runs already coded, so they are computed first and the
// entropy decoder is a tight loop; the pixels are then rebuilt from the residuals with no
// dependency between the blocks of a row. One walker, templated on an IO policy, runs in both
// directions (the encoder's IO records the tokens of a run, the decoder's decodes them), so the
// two cannot disagree.
//
// The passes run in the widest lanes the translation unit's ISA has (lanes.h); kFast = false
// runs a pass's scalar loop for every block, the reference its vector path is tested against.

#include <algorithm>
#include <cstdint>
#include <cstdlib>

#include <plx/core/image.h>

#include "contexts.h"
#include "rans.h"
#include "rows.h"

namespace plx::ptm::detail {
inline namespace PLX_PTM_KERNEL_NS {

// Bilinear upsample (weights 9, 3, 3, 1 over 16) of the parent m and its neighbours towards the
// pixel: `side` is the horizontal neighbour parent, `vert` the vertical one, `diag` the diagonal.
inline int upsample(int m, int side, int vert, int diag) {
    return (9 * m + 3 * side + 3 * vert + diag + 8) >> 4;
}

// Block-sum predictor: the n real pixels of a block sum to n*m + eps with eps in [0, n-1]
// (Marvie eq. 1 and 3), so the `rem` pixels not yet known sum to about n*m + (n-1)/2 - knownSum.
// Spread that sum by the bilinear shape: the pixel's upsample u plus the mean gap between the
// remaining sum and the upsamples of the remaining pixels (sumURemaining). Fixed point x4; C++
// division truncates toward zero. Result in [0, 255].
inline int predictBlockPixel(int n, int m, int knownSum, int sumURemaining, int rem, int u) {
    const int target4 = 4 * n * m + 2 * (n - 1) - 4 * knownSum;
    const int corr = (target4 - 4 * sumURemaining) / (4 * rem);
    return std::clamp(u + corr, 0, 255);
}

#if defined(__AVX2__)
// prepareRow for blocks 0..kLanes k - 1, W::kLanes blocks per step in int16 lanes (upsamples of
// bytes stay below 2^12; the shapes' w * detail / 8 within +-10400 also in a corrupt level,
// whose p11 may leave 0..255). Bit-exact with the scalar loop, which does the rest. Returns the
// first block not done.
template <class W, bool kShapeAbove>
int prepareRowVec(LevelRows& R, int lw, int c, bool firstRow) {
    using V = typename W::V;
    const size_t sw = size_t(lw + 2), o = size_t(c) * sw + 1, b = size_t(c) * size_t(lw);
    const Lane* pu = R.pu.data() + o;
    const Lane* pm = R.pm.data() + o;
    const Lane* pd = R.pd.data() + o;
    const Lane* act = R.prevAct.data() + o;
    const Lane* ea = R.prevEA.data() + o;
    const Lane* eb = R.prevEB.data() + o;
    const Lane* d01 = kShapeAbove ? R.detail01.data() + b : nullptr;
    const Lane* d11 = kShapeAbove ? R.detail11.data() + b : nullptr;
    const V eight = W::set(8), w = W::set(R.shapeEighths);
    const V interOne = W::set(c > 0 && !firstRow ? 1 : 0);
    // upsample(m, side, vert, diag) = (9 m + 3 (side + vert) + diag + 8) >> 4, all terms >= 0.
    auto up = [](V m9, V side, V vert, V diag) {
        const V sv = W::add(side, vert);
        return W::template shr<4>(W::add(W::add(m9, W::add(sv, W::template shl<1>(sv))), diag));
    };
    // 2 x + left + right of a padded statistics row.
    auto spread = [](const Lane* v, V mid) {
        return W::add(W::template shl<1>(mid), W::add(W::load(v - 1), W::load(v + 1)));
    };
    int bx = 0;
    for (; bx + W::kLanes <= lw; bx += W::kLanes) {
        const V mm = W::load(pm + bx), l = W::load(pm + bx - 1), r = W::load(pm + bx + 1);
        const V u = W::load(pu + bx), d = W::load(pd + bx);
        const V m9 = W::add(W::add(W::template shl<3>(mm), mm), eight);
        V u0 = up(m9, l, u, W::load(pu + bx - 1)), u1 = up(m9, r, u, W::load(pu + bx + 1));
        if constexpr (kShapeAbove) {  // + w * detail / 8, truncated
            u0 = W::add(u0, W::template divPow2<3>(W::mullo(w, W::load(d01 + bx))));
            u1 = W::add(u1, W::template divPow2<3>(W::mullo(w, W::load(d11 + bx))));
        }
        W::store(R.m.data() + b + size_t(bx), mm);
        W::store(R.u0.data() + b + size_t(bx), u0);
        W::store(R.u1.data() + b + size_t(bx), u1);
        W::store(R.u2.data() + b + size_t(bx), up(m9, l, d, W::load(pd + bx - 1)));
        W::store(R.u3.data() + b + size_t(bx), up(m9, r, d, W::load(pd + bx + 1)));
        const V grad = W::add(W::abs(W::sub(l, r)), W::abs(W::sub(u, d)));
        V act0;
        if (firstRow) {
            act0 = W::template shl<2>(grad);
        } else {  // ((3 a + left + right) >> 1) + grad
            const V a = W::load(act + bx);
            act0 = W::add(W::template shr<1>(W::add(spread(act + bx, a), a)), grad);
        }
        W::store(R.act0.data() + b + size_t(bx), act0);
        const V errA = spread(ea + bx, W::load(ea + bx));
        const V errB = spread(eb + bx, W::load(eb + bx));
        W::store(R.sel.data() + b + size_t(bx), W::keep(W::greater(errA, errB), interOne));
    }
    return bx;
}
#endif

// Pass 0 of a block row: parents, upsamples, activity and sub-predictor choice of every block
// of component c, from the lower level and the previous block row only (no clamping: the
// padded rows replicate the ends).
//
// kShapeAbove (blocks two pixels tall): the shapes of p00 and p10 corrected by w / 8 of the
// detail (value - upsample) of the pixel right above each, p01 and p11 of the block above
// (w = R.shapeEighths, the group's mode byte); C++ division, truncated toward zero. The
// block-sum predictor spreads the block's sum by these shapes, so the pixels above steer how it
// splits between the block's upper and lower rows. The details are zero on the first block row
// and from `full` on (odd widths: finishFullRow keeps only the full blocks'), which keeps those
// blocks' bilinear shapes.
// With AVX2, the first blocks by prepareRowVec in the widest lanes the ISA has (W: Lanes32
// with AVX-512, else Lanes16); kFast = false runs the scalar loop for every block (the
// reference that fast_paths_test compares the vector paths with).
template <bool kShapeAbove, bool kFast = true, class W = WidestLanes>
void prepareRow(LevelRows& R, int lw, int c, bool firstRow) {
    int start = 0;
#if defined(__AVX2__)
    if constexpr (kFast) start = prepareRowVec<W, kShapeAbove>(R, lw, c, firstRow);
#endif
    const size_t sw = size_t(lw + 2), o = size_t(c) * sw + 1, b = size_t(c) * size_t(lw);
    const Lane* __restrict pu = R.pu.data() + o;
    const Lane* __restrict pm = R.pm.data() + o;
    const Lane* __restrict pd = R.pd.data() + o;
    const Lane* __restrict act = R.prevAct.data() + o;
    const Lane* __restrict ea = R.prevEA.data() + o;
    const Lane* __restrict eb = R.prevEB.data() + o;
    Lane* __restrict m = R.m.data() + b;
    Lane* __restrict u0 = R.u0.data() + b;
    Lane* __restrict u1 = R.u1.data() + b;
    Lane* __restrict u2 = R.u2.data() + b;
    Lane* __restrict u3 = R.u3.data() + b;
    Lane* __restrict act0 = R.act0.data() + b;
    Lane* __restrict sel = R.sel.data() + b;
    const Lane* __restrict d01 = kShapeAbove ? R.detail01.data() + b : nullptr;
    const Lane* __restrict d11 = kShapeAbove ? R.detail11.data() + b : nullptr;
    const int inter = c > 0 && !firstRow ? 1 : 0;
    const int upWeight = firstRow ? 0 : 1, gradWeight = firstRow ? 4 : 1;
    const int w = R.shapeEighths;
    PLX_PTM_IVDEP
    for (int bx = start; bx < lw; ++bx) {
        const int mm = pm[bx], l = pm[bx - 1], r = pm[bx + 1], up = pu[bx], dn = pd[bx];
        m[bx] = mm;
        u0[bx] = upsample(mm, l, up, pu[bx - 1]);
        u1[bx] = upsample(mm, r, up, pu[bx + 1]);
        if constexpr (kShapeAbove) {
            u0[bx] += w * d01[bx] / 8;
            u1[bx] += w * d11[bx] / 8;
        }
        u2[bx] = upsample(mm, l, dn, pd[bx - 1]);
        u3[bx] = upsample(mm, r, dn, pd[bx + 1]);
        const int grad = std::abs(l - r) + std::abs(up - dn);
        act0[bx] = upWeight * ((3 * act[bx] + act[bx - 1] + act[bx + 1]) >> 1) + gradWeight * grad;
        const int errA = 2 * ea[bx] + ea[bx - 1] + ea[bx + 1];
        const int errB = 2 * eb[bx] + eb[bx - 1] + eb[bx + 1];
        sel[bx] = inter & (errB < errA ? 1 : 0);
    }
}

#if defined(__AVX2__)
// codeFullRow for blocks 0..kLanes k - 1 of component c, W::kLanes blocks per step in int16
// lanes (every intermediate of the block-sum predictor lies in -8160..5102, also with the
// shapes u0, u1 in -127..382; in a corrupt level, whose p11 may leave 0..255 and so move the
// next row's shapes to -510..893, they stay within +-15000). Bit-exact with the scalar loop,
// which does the rest. Returns the first block not done. kEncode: as codeFullRow's.
template <class W, bool kEncode>
int codeFullRowVec(LevelRows& R, int lw, int full, int c) {
    using V = typename W::V;
    const size_t pi = size_t(c) * size_t(lw), ri = size_t(c) * size_t(full);
    const Lane* m = R.m.data() + pi;
    const Lane* u0 = R.u0.data() + pi;
    const Lane* u1 = R.u1.data() + pi;
    const Lane* u2 = R.u2.data() + pi;
    const Lane* u3 = R.u3.data() + pi;
    const Lane* sel = R.sel.data() + pi;
    Lane* v0 = R.v0.data() + ri;
    Lane* v1 = R.v1.data() + ri;
    Lane* v2 = R.v2.data() + ri;
    uint8_t* z0 = R.z0.data() + ri;
    uint8_t* z1 = R.z1.data() + ri;
    uint8_t* z2 = R.z2.data() + ri;
    Lane* errA = R.errA.data() + ri;
    Lane* errB = R.errB.data() + ri;
    // Rows of this component (written), the previous one and the one before that (read).
    Lane* const own[3] = {R.compRow(R.rA0, c), R.compRow(R.rA1, c), R.compRow(R.rA2, c)};
    const Lane* const prev[3] = {R.compRow(R.rA0, c - 1), R.compRow(R.rA1, c - 1),
                                 R.compRow(R.rA2, c - 1)};
    const int before = LevelRows::secondBefore(c);  // as codeFullRow's
    const Lane* const prev2[3] = {R.compRow(R.rA0, before), R.compRow(R.rA1, before),
                                  R.compRow(R.rA2, before)};
    const bool inter = c > 0;
    const V zero = W::set(0), one = W::set(1), mask255 = W::set(255);
    int bx = 0;
    for (; bx + W::kLanes <= full; bx += W::kLanes) {
        const V mm = W::load(m + bx), w0 = W::load(u0 + bx), w1 = W::load(u1 + bx);
        const V w2 = W::load(u2 + bx), w3 = W::load(u3 + bx);
        const auto pickB = W::greater(W::load(sel + bx), zero);
        const V target = W::add(W::template shl<4>(mm), W::set(6));
        V eA = zero, eB = zero;
        // One stored pixel (codeFullRow's `one`): prediction pA from the block-sum predictor's
        // correction corr, B from the previous component's A-residual, value from the run value.
        auto pixel = [&](V u, V corr, Lane* rOwn, const Lane* rPrev, const Lane* rBefore,
                         uint8_t* z, Lane* v) {
            const V pA = W::clamp255(W::add(u, corr));
            V pB = pA;
            if (inter) {
                V r = W::load(rPrev + bx);  // |r| <= 255
                r = W::template divPow2<1>(W::add(r, W::load(rBefore + bx)));
                pB = W::clamp255(W::add(pA, r));
            }
            const V pred = W::select(pickB, pA, pB);
            V val;
            if constexpr (kEncode) {  // z = zigzag(int8_t(v - pred))
                val = W::load(v + bx);
                const V d = W::template sar<8>(W::template shl<8>(W::sub(val, pred)));
                W::storeBytes(z + bx, W::bitXor(W::template shl<1>(d), W::template sar<15>(d)));
            } else {  // v = (pred + unzigzag(z)) & 255
                const V zz = W::widen(z + bx);
                const V unz = W::bitXor(W::template shr<1>(zz), W::sub(zero, W::bitAnd(zz, one)));
                val = W::bitAnd(W::add(pred, unz), mask255);
                W::store(v + bx, val);
            }
            W::store(rOwn + bx, W::sub(val, pA));
            eA = W::add(eA, W::abs(W::sub(val, pA)));
            eB = W::add(eB, W::abs(W::sub(val, pB)));
            return val;
        };
        // predictBlockPixel(4, m, known, sumU, rem, u): corr = (16 m + 6 - 4 known - 4 sumU)
        // / (4 rem), truncated.
        auto times4 = [](V x) { return W::template shl<2>(x); };
        const V s23 = W::add(w2, w3), s123 = W::add(w1, s23);
        const V a = pixel(w0, W::template divPow2<4>(W::sub(target, times4(W::add(w0, s123)))),
                          own[0], prev[0], prev2[0], z0, v0);
        const V b =
            pixel(w1, W::div3(W::template divPow2<2>(W::sub(target, times4(W::add(a, s123))))),
                  own[1], prev[1], prev2[1], z1, v1);
        pixel(w2, W::template divPow2<3>(W::sub(target, times4(W::add(W::add(a, b), s23)))),
              own[2], prev[2], prev2[2], z2, v2);
        W::store(errA + bx, eA);
        W::store(errB + bx, eB);
    }
    return bx;
}
#endif

// Prediction and reconstruction of the three stored pixels of every full block of a row, for
// component c. Encode: values v0..v2 to run values z0..z2; decode: the reverse. Sub-predictor A
// is the block-sum predictor (predictBlockPixel); B (components >= 1) is clamp(A + r, 0, 255)
// with r the previous component's A-residual at the same pixel; `sel` (pass 0) picks B. No
// dependency between blocks: with AVX2, the first blocks by codeFullRowVec in the widest lanes
// the ISA has (W, as prepareRow's); kFast = false runs the scalar loop for every block (the reference
// of fast_paths_test).
// For components >= 2, r is the mean (truncated) of the A-residuals of the two components
// before: each carries the rounding noise of its own JPEG decode, which the mean halves.
template <bool kEncode, bool kFast = true, class W = WidestLanes>
void codeFullRow(LevelRows& R, int lw, int full, int c) {
    const size_t pi = size_t(c) * size_t(lw), ri = size_t(c) * size_t(full);
    const Lane* __restrict m = R.m.data() + pi;
    const Lane* __restrict u0 = R.u0.data() + pi;
    const Lane* __restrict u1 = R.u1.data() + pi;
    const Lane* __restrict u2 = R.u2.data() + pi;
    const Lane* __restrict u3 = R.u3.data() + pi;
    const Lane* __restrict sel = R.sel.data() + pi;
    Lane* __restrict v0 = R.v0.data() + ri;
    Lane* __restrict v1 = R.v1.data() + ri;
    Lane* __restrict v2 = R.v2.data() + ri;
    uint8_t* __restrict z0 = R.z0.data() + ri;
    uint8_t* __restrict z1 = R.z1.data() + ri;
    uint8_t* __restrict z2 = R.z2.data() + ri;
    Lane* __restrict errA = R.errA.data() + ri;
    Lane* __restrict errB = R.errB.data() + ri;
    Lane* __restrict rA0 = R.compRow(R.rA0, c);  // this component's, written
    Lane* __restrict rA1 = R.compRow(R.rA1, c);
    Lane* __restrict rA2 = R.compRow(R.rA2, c);
    const Lane* __restrict pr0 = R.compRow(R.rA0, c - 1);  // the previous component's
    const Lane* __restrict pr1 = R.compRow(R.rA1, c - 1);
    const Lane* __restrict pr2 = R.compRow(R.rA2, c - 1);
    // The one before that (LevelRows::secondBefore).
    const int before = LevelRows::secondBefore(c);
    const Lane* __restrict pq0 = R.compRow(R.rA0, before);
    const Lane* __restrict pq1 = R.compRow(R.rA1, before);
    const Lane* __restrict pq2 = R.compRow(R.rA2, before);
    const int inter = c > 0 ? 1 : 0;
    // One stored pixel: prediction from A (and B, from the earlier components' A-residuals p and
    // q), value <-> run value, this component's A-residual kept for the next ones.
    auto one = [&](int pA, int p, int q, Lane& rA, Lane& v, uint8_t& z, int s, int& eA, int& eB) {
        const int r = (p + q) / 2;
        const int pB = inter ? std::clamp(pA + r, 0, 255) : pA;
        const int pred = s ? pB : pA;
        if constexpr (kEncode)
            z = uint8_t(zigzag(int(int8_t(uint8_t(v - pred)))));
        else
            v = (pred + unzigzagFast(z)) & 255;
        rA = v - pA;
        eA += std::abs(v - pA);
        eB += std::abs(v - pB);
    };
    int start = 0;
#if defined(__AVX2__)
    if constexpr (kFast) start = codeFullRowVec<W, kEncode>(R, lw, full, c);
#endif
    PLX_PTM_IVDEP
    for (int bx = start; bx < full; ++bx) {
        const int mm = m[bx], s = sel[bx];
        int eA = 0, eB = 0;
        one(predictBlockPixel(4, mm, 0, u0[bx] + u1[bx] + u2[bx] + u3[bx], 4, u0[bx]), pr0[bx],
            pq0[bx], rA0[bx], v0[bx], z0[bx], s, eA, eB);
        one(predictBlockPixel(4, mm, v0[bx], u1[bx] + u2[bx] + u3[bx], 3, u1[bx]), pr1[bx], pq1[bx],
            rA1[bx], v1[bx], z1[bx], s, eA, eB);
        one(predictBlockPixel(4, mm, v0[bx] + v1[bx], u2[bx] + u3[bx], 2, u2[bx]), pr2[bx], pq2[bx],
            rA2[bx], v2[bx], z2[bx], s, eA, eB);
        errA[bx] = eA;
        errB[bx] = eB;
    }
}

#if defined(__AVX2__)
// finishFullRow (below) for blocks 0..kLanes k - 1, W::kLanes blocks per step in int16 lanes
// (p11 within -765..1275 and r3 within +-3900 also in a corrupt level). Bit-exact with the
// scalar loops, which do the rest. Returns the first block not done; ORs the range check's
// flags into bad.
template <class W>
int finishFullRowVec(LevelRows& R, int lw, int full, int c, unsigned& bad) {
    using V = typename W::V;
    const size_t pi = size_t(c) * size_t(lw), ri = size_t(c) * size_t(full);
    const size_t si = size_t(c) * size_t(lw + 2) + 1;
    Lane* own3 = R.compRow(R.r3, c);
    const Lane* p3 = R.compRow(R.r3, c - 1);
    const Lane* q3 = R.compRow(R.r3, LevelRows::secondBefore(c));
    const V zero = W::set(0);
    auto flags = W::none();
    int bx = 0;
    for (; bx + W::kLanes <= full; bx += W::kLanes) {
        const size_t p = pi + size_t(bx), r = ri + size_t(bx), st = si + size_t(bx);
        const V v0 = W::load(R.v0.data() + r), v1 = W::load(R.v1.data() + r);
        const V v2 = W::load(R.v2.data() + r), u3 = W::load(R.u3.data() + p);
        const V ep = W::widen(R.ze.data() + r);
        const V last = W::sub(W::add(W::template shl<2>(W::load(R.m.data() + p)), ep),
                              W::add(W::add(v0, v1), v2));  // eq. (3)
        flags = W::either(flags, W::greater(ep, W::set(3)));
        flags = W::either(flags, W::greater(zero, last));
        flags = W::either(flags, W::greater(last, W::set(255)));
        W::store(R.v3.data() + r, last);
        {
            W::store(R.detail01.data() + p, W::sub(v2, W::load(R.u2.data() + p)));
            W::store(R.detail11.data() + p, W::sub(last, u3));
        }
        W::store(R.curAct.data() + st,
                 W::add(W::add(W::magnitudes(R.z0.data() + r), W::magnitudes(R.z1.data() + r)),
                        W::magnitudes(R.z2.data() + r)));
        V ea = W::load(R.errA.data() + r), eb = W::load(R.errB.data() + r);
        {
            const V planar = W::sub(W::add(v1, v2), v0);
            const V r3 = W::sub(W::sub(W::template shl<1>(last), planar), u3);
            W::store(own3 + bx, r3);
            if (c > 0) {  // |r3| / 2 and |r3 - B's correction| / 2
                const V corr = W::template sar<1>(W::add(W::load(p3 + bx), W::load(q3 + bx)));
                ea = W::add(ea, W::template shr<1>(W::abs(r3)));
                eb = W::add(eb, W::template shr<1>(W::abs(W::sub(r3, corr))));
            }
        }
        W::store(R.curEA.data() + st, ea);
        W::store(R.curEB.data() + st, eb);
    }
    bad |= unsigned(W::any(flags));
    return bx;
}
#endif

// p11 of the full blocks by eq. (3) and the row's statistics for the next row. Returns a
// non-zero value on an eps >= 4 or a p11 outside 0..255.
// Also keeps the detail of p01 and p11 (value - upsample; u2, u3 are never corrected) for the
// next block row's prepareRow, and p11's half-step residual for the next components (r3), and
// adds p11's errors under A and B to the block's sub-predictor statistics (components >= 1), so
// that the next row's choice between A and B also weighs p11.
// With AVX2, the first blocks by finishFullRowVec in the widest lanes the ISA has (W, as
// prepareRow's); kFast = false runs the scalar loops for every block (the reference that
// fast_paths_test compares the vector paths with).
template <bool kFast = true, class W = WidestLanes>
unsigned finishFullRow(LevelRows& R, int lw, int full, int c) {
    const size_t pi = size_t(c) * size_t(lw), ri = size_t(c) * size_t(full);
    const size_t si = size_t(c) * size_t(lw + 2) + 1;
    const Lane* __restrict m = R.m.data() + pi;
    const uint8_t* __restrict z0 = R.z0.data() + ri;
    const uint8_t* __restrict z1 = R.z1.data() + ri;
    const uint8_t* __restrict z2 = R.z2.data() + ri;
    const uint8_t* __restrict ze = R.ze.data() + ri;
    const Lane* __restrict v0 = R.v0.data() + ri;
    const Lane* __restrict v1 = R.v1.data() + ri;
    const Lane* __restrict v2 = R.v2.data() + ri;
    Lane* __restrict v3 = R.v3.data() + ri;
    const Lane* __restrict errA = R.errA.data() + ri;
    const Lane* __restrict errB = R.errB.data() + ri;
    Lane* __restrict act = R.curAct.data() + si;
    Lane* __restrict ea = R.curEA.data() + si;
    Lane* __restrict eb = R.curEB.data() + si;
    const Lane* __restrict u2 = R.u2.data() + pi;
    const Lane* __restrict u3 = R.u3.data() + pi;
    Lane* __restrict d01 = R.detail01.data() + pi;
    Lane* __restrict d11 = R.detail11.data() + pi;
    unsigned bad = 0;
    int start = 0;
#if defined(__AVX2__)
    if constexpr (kFast) start = finishFullRowVec<W>(R, lw, full, c, bad);
#endif
    // No ivdep here: `bad` is a reduction, and GCC 12 vectorised this loop wrongly under ivdep
    // in the scalar ISA of the sanitizer build (valid levels failed the range check).
    for (int bx = start; bx < full; ++bx) {
        const int ep = ze[bx];
        const int last = 4 * m[bx] + ep - v0[bx] - v1[bx] - v2[bx];  // eq. (3)
        bad |= unsigned(ep >= 4) | unsigned(unsigned(last) > 255u);
        v3[bx] = last;
        d01[bx] = v2[bx] - u2[bx];
        d11[bx] = last - u3[bx];
        act[bx] = magnitude(z0[bx]) + magnitude(z1[bx]) + magnitude(z2[bx]);
        ea[bx] = errA[bx];
        eb[bx] = errB[bx];
    }
    Lane* __restrict r3 = R.compRow(R.r3, c);
    PLX_PTM_IVDEP
    for (int bx = start; bx < full; ++bx)
        r3[bx] = 2 * v3[bx] - (v1[bx] + v2[bx] - v0[bx]) - u3[bx];
    if (c == 0) return bad;
    // B's p11 correction as epsContexts' (c == 1: (p + p) >> 1 = p).
    const Lane* __restrict p3 = R.compRow(R.r3, c - 1);
    const Lane* __restrict q3 = R.compRow(R.r3, LevelRows::secondBefore(c));
    PLX_PTM_IVDEP
    for (int bx = start; bx < full; ++bx) {
        ea[bx] += std::abs(r3[bx]) / 2;
        eb[bx] += std::abs(r3[bx] - ((p3[bx] + q3[bx]) >> 1)) / 2;
    }
    return bad;
}

// Byte shuffles that interleave three planes of 16 bytes into 48: output byte g = 16 j + k is
// pixel g / 3 of plane g % 3; mask 3 j + ch picks plane ch's bytes of output vector j.
struct RgbShuffles {
    alignas(16) int8_t mask[9][16]{};
    constexpr RgbShuffles() {
        for (int j = 0; j < 3; ++j)
            for (int ch = 0; ch < 3; ++ch)
                for (int k = 0; k < 16; ++k) {
                    const int g = 16 * j + k;
                    mask[3 * j + ch][k] = g % 3 == ch ? int8_t(g / 3) : int8_t(-128);
                }
    }
};
inline constexpr RgbShuffles kRgbShuffles{};

// One pixel row of the full blocks of a block row, interleaved: pixels 2 bx and 2 bx + 1 of
// component c are a[c * full + bx] and b[c * full + bx] (planar rows of the walker).
// Values outside 0..255 (only in a level that fails eq. 3's range check, whose pixels are then
// discarded) may differ between the vector and the scalar path.
template <int C>
void writeFullRow(const Lane* __restrict a, const Lane* __restrict b, int full,
                  uint8_t* __restrict row) {
    const size_t n = size_t(full);
    size_t start = 0;
#if defined(__AVX2__)
    // Sixteen blocks (32 pixels) per step: each component's 16 + 16 values packed to bytes and
    // interleaved into one planar 32-pixel row, then the C planes interleaved by byte shuffles.
    auto bytes16 = [](const Lane* p) {
        auto ld = [p](int i) {
            return _mm_loadu_si128(reinterpret_cast<const __m128i*>(p + 8 * i));
        };
        return _mm_packus_epi16(ld(0), ld(1));
    };
    for (; start + 16 <= n; start += 16) {
        __m128i lo[C], hi[C];  // pixels 0..15 and 16..31 of the step, per component
        for (size_t c = 0; c < size_t(C); ++c) {
            const __m128i va = bytes16(a + c * n + start), vb = bytes16(b + c * n + start);
            lo[c] = _mm_unpacklo_epi8(va, vb);
            hi[c] = _mm_unpackhi_epi8(va, vb);
        }
        uint8_t* out = row + 2 * start * C;
        for (int h = 0; h < 2; ++h) {
            const __m128i* q = h ? hi : lo;
            __m128i* o = reinterpret_cast<__m128i*>(out + size_t(h) * 16 * C);
            if constexpr (C == 1) {
                _mm_storeu_si128(o, q[0]);
            } else if constexpr (C == 2) {
                _mm_storeu_si128(o, _mm_unpacklo_epi8(q[0], q[1]));
                _mm_storeu_si128(o + 1, _mm_unpackhi_epi8(q[0], q[1]));
            } else if constexpr (C == 4) {
                const __m128i rg0 = _mm_unpacklo_epi8(q[0], q[1]);
                const __m128i rg1 = _mm_unpackhi_epi8(q[0], q[1]);
                const __m128i ba0 = _mm_unpacklo_epi8(q[2], q[3]);
                const __m128i ba1 = _mm_unpackhi_epi8(q[2], q[3]);
                _mm_storeu_si128(o, _mm_unpacklo_epi16(rg0, ba0));
                _mm_storeu_si128(o + 1, _mm_unpackhi_epi16(rg0, ba0));
                _mm_storeu_si128(o + 2, _mm_unpacklo_epi16(rg1, ba1));
                _mm_storeu_si128(o + 3, _mm_unpackhi_epi16(rg1, ba1));
            } else {
                const auto* sh = reinterpret_cast<const __m128i*>(kRgbShuffles.mask);
#pragma GCC unroll 3
                for (int j = 0; j < 3; ++j) {
                    const __m128i v0 = _mm_shuffle_epi8(q[0], _mm_load_si128(sh + 3 * j));
                    const __m128i v1 = _mm_shuffle_epi8(q[1], _mm_load_si128(sh + 3 * j + 1));
                    const __m128i v2 = _mm_shuffle_epi8(q[2], _mm_load_si128(sh + 3 * j + 2));
                    _mm_storeu_si128(o + j, _mm_or_si128(_mm_or_si128(v0, v1), v2));
                }
            }
        }
    }
#endif
PLX_PTM_IVDEP
    for (size_t bx = start; bx < n; ++bx) {
#pragma GCC unroll 4
        for (size_t c = 0; c < size_t(C); ++c) {
            row[2 * bx * C + c] = uint8_t(a[c * n + bx]);
            row[2 * bx * C + C + c] = uint8_t(b[c * n + bx]);
        }
    }
}

// The full blocks of a block row, component-major, each component's p00, p10 and p01
// runs, its pixels, its eps run and its p11 before the next component's, so that the next
// one's predictions and contexts see them. Four runs per component instead of four in all: the
// runs of a 1024-wide level stay 512 symbols long, sixteen vector rounds each.
template <int C, class IO>
unsigned walkFullRowByComponent(LevelRows& R, int lw, int full, IO& io) {
    unsigned bad = 0;
    for (int c = 0; c < C; ++c) {
        const size_t ri = size_t(c) * size_t(full);
        uint16_t* ctx = R.ctx.data() + ri;
        fullRunContexts<0>(R, lw, full, c, io.ctxMap(c, 0));
        io.template run<true>(ctx, full, R.z0.data() + ri);
        fullRunContexts<1>(R, lw, full, c, io.ctxMap(c, 1));
        io.template run<true>(ctx, full, R.z1.data() + ri);
        fullRunContexts<2>(R, lw, full, c, io.ctxMap(c, 2));
        io.template run<true>(ctx, full, R.z2.data() + ri);
        if constexpr (!IO::kEncode) codeFullRow<false>(R, lw, full, c);
        epsContexts<IO::kEncode>(R, lw, full, c, io.ctxMap(c, 3));
        io.runEps(c, ctx, full, R.ze.data() + ri);
        bad |= finishFullRow(R, lw, full, c);
    }
    return bad;
}

// Group k >= 1. Returns false (decode only) on an eps >= n or a pixel of eq. (3)
// outside 0..255.
template <int C, class IO>
bool walkLevel(const ByteImage& low, uint8_t* cur, int width, int height, IO& ioRef) {
    // A local copy whose address does not escape: the pixel stores (uint8_t may alias anything)
    // then do not force the coder state out of registers.
    IO io = std::move(ioRef);
    const int lw = low.width, lh = low.height, full = width / 2;  // full: 2-wide blocks per row
    const size_t stride = size_t(width) * C, lowStride = size_t(lw) * C;
    const size_t sw = size_t(lw + 2);
    LevelRows R(C, lw, io.shapeEighths);
    unsigned bad = 0;
    for (int by = 0; by < lh; ++by) {
        const int y0 = 2 * by, y1 = std::min(y0 + 1, height - 1);
        const bool tall = y1 > y0;  // blocks of this row have two pixel rows
        uint8_t* r0 = cur + size_t(y0) * stride;
        uint8_t* r1 = cur + size_t(y1) * stride;
        const uint8_t* lm = low.bytes.data() + size_t(by) * lowStride;
        const uint8_t* lu = low.bytes.data() + size_t(std::max(by - 1, 0)) * lowStride;
        const uint8_t* ld = low.bytes.data() + size_t(std::min(by + 1, lh - 1)) * lowStride;
        if (by == 0) {
            for (int c = 0; c < C; ++c) {
                planarRow<C>(lu, lw, c, R.pu.data() + size_t(c) * sw);
                planarRow<C>(lm, lw, c, R.pm.data() + size_t(c) * sw);
            }
        } else {  // rows by - 1 and by are the previous block row's by and by + 1
            std::swap(R.pu, R.pm);
            std::swap(R.pm, R.pd);
        }
        for (int c = 0; c < C; ++c) {
            planarRow<C>(ld, lw, c, R.pd.data() + size_t(c) * sw);
            if (tall)
                prepareRow<true>(R, lw, c, by == 0);
            else
                prepareRow<false>(R, lw, c, by == 0);
        }
        uint16_t* ctx = R.ctx.data();
        if (tall && full > 0) {
            if constexpr (IO::kEncode) {
                for (int bx = 0; bx < full; ++bx)
                    for (int c = 0; c < C; ++c) {
                        const size_t i = size_t(c) * size_t(full) + size_t(bx);
                        const size_t px = size_t(2 * bx) * C + size_t(c);
                        R.v0[i] = r0[px];
                        R.v1[i] = r0[px + C];
                        R.v2[i] = r1[px];
                        R.v3[i] = r1[px + C];
                    }
                for (int c = 0; c < C; ++c)
                    codeFullRow<true>(R, lw, full, c);
            }
            bad |= walkFullRowByComponent<C>(R, lw, full, io);
            if constexpr (!IO::kEncode) {
                writeFullRow<C>(R.v0.data(), R.v1.data(), full, r0);
                writeFullRow<C>(R.v2.data(), R.v3.data(), full, r1);
            }
        }
        // Blocks with two real pixels: the last column's 1x2 block (odd width) or the last
        // row's 2x1 blocks (odd height). p00 is coded, the other pixel follows from eq. (3).
        const int pairFrom = tall ? full : 0;
        const int pairTo = tall ? (width & 1 ? lw : full) : full;
        const int np = pairTo - pairFrom;
        if (np > 0) {
            for (int c = 0; c < C; ++c)
                for (int k = 0; k < np; ++k) {
                    const size_t j = size_t(c) * size_t(np) + size_t(k);
                    const size_t i = size_t(c) * size_t(lw) + size_t(pairFrom + k);
                    ctx[j] = uint16_t(io.ctxMap(c, 0)(bucketOf(R.act0[i])));
                    const int uo = tall ? R.u2[i] : R.u1[i];  // the other pixel: p01 or p10
                    const int pred = predictBlockPixel(2, R.m[i], 0, R.u0[i] + uo, 2, R.u0[i]);
                    R.v3[j] = pred;
                    if constexpr (IO::kEncode) {
                        const size_t px = size_t(2 * (pairFrom + k)) * C + size_t(c);
                        const int a = r0[px], o = tall ? r1[px] : r0[px + C];
                        R.z0[j] = uint8_t(zigzag(int(int8_t(uint8_t(a - pred)))));
                        R.ze[j] = uint8_t(a + o - 2 * R.m[i]);
                    }
                }
            const int cnt = C * np;
            io.template run<true>(ctx, cnt, R.z0.data());
            for (int j = 0; j < cnt; ++j)
                ctx[j] = uint16_t(io.ctxMap(j / np, 3)(kEpsContexts - 2));
            io.template run<false>(ctx, cnt, R.ze.data());
            for (int c = 0; c < C; ++c)
                for (int k = 0; k < np; ++k) {
                    const size_t j = size_t(c) * size_t(np) + size_t(k);
                    const size_t i = size_t(c) * size_t(lw) + size_t(pairFrom + k);
                    const int a = (R.v3[j] + unzigzagFast(R.z0[j])) & 255;
                    const int ep = R.ze[j];
                    const int last = 2 * R.m[i] + ep - a;  // eq. (3), n = 2
                    bad |= unsigned(ep >= 2) | unsigned(unsigned(last) > 255u);
                    const size_t px = size_t(2 * (pairFrom + k)) * C + size_t(c);
                    if constexpr (!IO::kEncode) {
                        r0[px] = uint8_t(a);
                        (tall ? r1[px] : r0[px + C]) = uint8_t(last);
                    }
                    const int e = magnitude(R.z0[j]);
                    const size_t s = size_t(c) * sw + size_t(pairFrom + k) + 1;
                    R.curAct[s] = 3 * e;
                    R.curEA[s] = 3 * e;
                    R.curEB[s] = 3 * e + 3;
                }
        }
        if (!tall && (width & 1)) {  // the 1x1 corner block: eps = 0, the pixel is its parent
            if constexpr (!IO::kEncode)
                for (int c = 0; c < C; ++c)
                    r0[size_t(width - 1) * C + size_t(c)] = lm[size_t(lw - 1) * C + size_t(c)];
        }
        for (int c = 0; c < C; ++c) {  // replicate the row's ends for the next row's diagonals
            for (auto* v : {&R.curAct, &R.curEA, &R.curEB}) {
                Lane* s = v->data() + size_t(c) * sw;
                s[0] = s[1];
                s[lw + 1] = s[lw];
            }
        }
        std::swap(R.prevAct, R.curAct);
        std::swap(R.prevEA, R.curEA);
        std::swap(R.prevEB, R.curEB);
    }
    ioRef = std::move(io);
    return bad == 0;
}

}  // namespace PLX_PTM_KERNEL_NS
}  // namespace plx::ptm::detail
