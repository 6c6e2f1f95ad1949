#pragma once
// Private: the working rows of the level walker (walker.h), one block row at a time, planar.

#include <cstdint>
#include <vector>

#include "lanes.h"

namespace plx::ptm::detail {
inline namespace PLX_PTM_KERNEL_NS {

// |unzigzag(z)| and unzigzag(z), branch-free.
inline int magnitude(int z) { return (z + 1) >> 1; }
inline int unzigzagFast(int z) { return (z >> 1) ^ -(z & 1); }

// Per-level working rows of walkLevel, planar. Parent rows and statistics are padded by
// one replicated entry at each end: index c * (lw + 2) + bx + 1. Block rows: c * lw + bx.
// Runs: c * n + bx for the n blocks of the run.
struct LevelRows {
    Row<Lane> pu, pm, pd;                    // lower level rows by - 1, by, by + 1
    Row<Lane> m, u0, u1, u2, u3, act0, sel;  // per block of the row
    Row<uint8_t> z0, z1, z2, ze;            // run values
    Row<Lane> v0, v1, v2, v3;               // pixel values of the full blocks
    Row<Lane> errA, errB;
    // A-residuals (value - A prediction) of p00, p10, p01, per component: row c * lw + bx, and
    // a row C of zeros that stands for the component before component 0.
    Row<Lane> rA0, rA1, rA2;
    Row<uint16_t> ctx;
    Row<Lane> mag;          // scratch: magnitudes of a run, padded
    Row<uint8_t> magBytes;  // the same as bytes (fullRunContextsAvx2)
    // Statistics of the previous and the current block row: activity (sum of |residual|) and
    // sub-predictor errors.
    Row<Lane> prevAct, prevEA, prevEB, curAct, curEA, curEB;
    // Weight of the detail above in the shapes of p00 and p10, in eighths (the group's mode
    // byte, 0..kMaxShapeEighths).
    int shapeEighths = 0;
    // The detail (value - upsample) of p01 and p11 of each full block
    // of the previous block row, the pixels right above this row's p00 and p10 (zero before the
    // second block row and beyond the full blocks).
    Row<Lane> detail01, detail11;
    // p11's half-step residual 2 p11 - (planar + u3), per component as rA0..rA2.
    Row<Lane> r3;
    int comps = 0, lw = 0;
    // Component c's row of a per-component array (c < 0: the row of zeros).
    Lane* compRow(Row<Lane>& v, int c) {
        return v.data() + size_t(c < 0 ? comps : c) * size_t(lw);
    }
    // The second component before c, whose residuals it averages with the previous
    // one's: c - 2, or for c < 2 the previous one again (its mean with itself is itself; for
    // c == 0 both are the row of zeros).
    static int secondBefore(int c) { return c >= 2 ? c - 2 : c - 1; }
    LevelRows(int C, int levelWidth, int groupShapeEighths)
        : shapeEighths(groupShapeEighths), comps(C), lw(levelWidth) {
        const size_t n = size_t(C) * size_t(lw), s = size_t(C) * size_t(lw + 2);
        for (auto* v : {&m, &u0, &u1, &u2, &u3, &act0, &sel, &v0, &v1, &v2, &v3, &errA, &errB})
            v->assign(n, 0);
        for (auto* v : {&detail01, &detail11}) v->assign(n, 0);
        for (auto* v : {&z0, &z1, &z2, &ze}) v->assign(n, 0);
        for (auto* v : {&rA0, &rA1, &rA2, &r3}) v->assign(n + size_t(lw), 0);
        ctx.assign(n, 0);
        mag.assign(size_t(lw) + 2, 0);
        magBytes.assign(size_t(lw) + 2, 0);
        for (auto* v : {&pu, &pm, &pd, &prevAct, &prevEA, &prevEB, &curAct, &curEA, &curEB})
            v->assign(s, 0);
    }
};

// Deinterleaves component c of a lower-level row into a padded planar row.
template <int C>
void planarRow(const uint8_t* row, int lw, int c, Lane* out) {
    for (int bx = 0; bx < lw; ++bx) out[bx + 1] = row[size_t(bx) * C + size_t(c)];
    out[0] = out[1];
    out[lw + 1] = out[lw];
}

}  // namespace PLX_PTM_KERNEL_NS
}  // namespace plx::ptm::detail
