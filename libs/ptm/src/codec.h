#pragma once
// Private: the plane layout of a level group and the one walker that both the encoder (values to
// residuals) and the decoder (residuals to values) run, so that the two cannot disagree.
//
// Group k >= 1 (level size w x h, lower level lw x lh = ceil(w/2) x ceil(h/2), C components)
// holds, in order: for each component the packed residual-error plane (Marvie eq. 3's epsilon,
// 2 bits per block, 4 blocks per byte, first block in the low bits); then the partial level as
// 3*C pixel planes, position-major: p00 of every block with n >= 2 real pixels (component 0, 1,
// ...), then p10 of every full 2x2 block, then p01 of every full block. The last real pixel of
// each block (p11 for a full block) is not stored: eq. (3) gives it. Group 0 holds C planes of
// the whole smallest level. Coder kRaw stores values, kPredictZstd prediction residuals mod 256.

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include <plx/core/image.h>
#include <plx/ptm/mip.h>

namespace plx::ptm::detail {

struct GroupLayout {
    int components = 0;
    size_t epsBytes = 0;     // per component
    size_t multiBlocks = 0;  // blocks with 2 or 4 real pixels (they store p00)
    size_t fullBlocks = 0;   // full 2x2 blocks (they also store p10 and p01)
    size_t basePixels = 0;   // group 0 only: pixels of the smallest level

    size_t payloadBytes() const {
        return basePixels ? basePixels * size_t(components)
                          : size_t(components) * (epsBytes + multiBlocks + 2 * fullBlocks);
    }
    size_t epsPlane(int c) const { return size_t(c) * epsBytes; }
    size_t pixelPlane(int pos, int c) const {
        size_t base = size_t(components) * epsBytes;
        if (pos == 0) return base + size_t(c) * multiBlocks;
        base += size_t(components) * multiBlocks;
        return base + size_t((pos - 1) * components + c) * fullBlocks;
    }
};

// Layout of the group that rebuilds level `cur` (k >= 1) or, with lowest = true, level 0.
inline GroupLayout groupLayout(LevelSize cur, int components, bool lowest) {
    GroupLayout g;
    g.components = components;
    if (lowest) {
        g.basePixels = size_t(cur.width) * size_t(cur.height);
        return g;
    }
    LevelSize low = lowerLevelSize(cur);
    size_t blocks = size_t(low.width) * size_t(low.height);
    g.epsBytes = (blocks + 3) / 4;
    g.fullBlocks = size_t(cur.width / 2) * size_t(cur.height / 2);
    g.multiBlocks = blocks - ((cur.width & 1) && (cur.height & 1) ? 1 : 0);
    return g;
}

// LOCO-I median edge detector for the smallest level (causal neighbours W, N, NW).
inline int predictMed(int x, int y, int w, int n, int nw) {
    if (x == 0) return y == 0 ? 0 : n;
    if (y == 0) return w;
    const int mx = std::max(w, n), mn = std::min(w, n);
    return nw >= mx ? mn : (nw <= mn ? mx : w + n - nw);
}

// Bilinear upsample (weights 9, 3, 3, 1 over 16) of the parent m and its neighbours towards the
// pixel: `side` is the horizontal neighbour parent, `vert` the vertical one, `diag` the diagonal.
inline int upsample(int m, int side, int vert, int diag) {
    return (9 * m + 3 * side + 3 * vert + diag + 8) >> 4;
}

// Block-sum predictor (chosen by measurement, docs/ptm-results.md): the n real pixels of a block
// sum to n*m + eps with eps in [0, n-1] (eq. 1 and 3), so the `rem` pixels not yet known sum to
// about n*m + (n-1)/2 - knownSum. Spread that sum by the bilinear shape: the pixel's upsample u
// plus the mean gap between the remaining sum and the upsamples of the remaining pixels
// (sumURemaining). Fixed point x4; C++ division truncates toward zero. Result in [0, 255].
inline int predictBlockPixel(int n, int m, int knownSum, int sumURemaining, int rem, int u) {
    const int target4 = 4 * n * m + 2 * (n - 1) - 4 * knownSum;
    const int corr = (target4 - 4 * sumURemaining) / (4 * rem);
    return std::clamp(u + corr, 0, 255);
}

// Walks level `cur` block by block in raster order. Encode: reads cur, writes payload planes.
// Decode: reads payload planes, writes cur; returns false if the payload is inconsistent (an
// epsilon >= n or a reconstructed pixel outside 0..255). low is the complete lower level.
template <int C, bool kPredict, bool kEncode>
bool walkLevel(const ByteImage& low, uint8_t* cur, int width, int height, uint8_t* payload) {
    const GroupLayout g = groupLayout({width, height}, C, false);
    const size_t stride = size_t(width) * C, lowStride = size_t(low.width) * C;
    uint8_t* eps[C];
    uint8_t* p0[C];
    uint8_t* p1[C];
    uint8_t* p2[C];
    for (int c = 0; c < C; ++c) {
        eps[c] = payload + g.epsPlane(c);
        p0[c] = payload + g.pixelPlane(0, c);
        p1[c] = payload + g.pixelPlane(1, c);
        p2[c] = payload + g.pixelPlane(2, c);
    }
    size_t block = 0, iMulti = 0, iFull = 0;
    unsigned bad = 0;
    for (int by = 0; by < low.height; ++by) {
        const int y0 = 2 * by, y1 = std::min(y0 + 1, height - 1);
        uint8_t* r0 = cur + size_t(y0) * stride;
        uint8_t* r1 = cur + size_t(y1) * stride;
        const uint8_t* lm = low.bytes.data() + size_t(by) * lowStride;
        const uint8_t* lu = low.bytes.data() + size_t(std::max(by - 1, 0)) * lowStride;
        const uint8_t* ld = low.bytes.data() + size_t(std::min(by + 1, low.height - 1)) * lowStride;
        for (int bx = 0; bx < low.width; ++bx, ++block) {
            const int x0 = 2 * bx, x1 = std::min(x0 + 1, width - 1);
            const int nx = x1 > x0 ? 2 : 1, ny = y1 > y0 ? 2 : 1, n = nx * ny;
            const size_t xl = size_t(std::max(bx - 1, 0)) * C, xm = size_t(bx) * C;
            const size_t xr = size_t(std::min(bx + 1, low.width - 1)) * C;
            const size_t epsByte = block >> 2;
            const int epsShift = int(block & 3) * 2;
            for (int c = 0; c < C; ++c) {
                const int m = lm[xm + c];
                uint8_t* a = r0 + size_t(x0) * C + c;  // p00
                uint8_t* b = r0 + size_t(x1) * C + c;  // p10 (== p00 when nx == 1)
                uint8_t* d = r1 + size_t(x0) * C + c;  // p01 (== p00 when ny == 1)
                uint8_t* e = r1 + size_t(x1) * C + c;  // p11, the last real pixel
                int u0 = 0, u1 = 0, u2 = 0, u3 = 0;
                if constexpr (kPredict) {
                    const int l = lm[xl + c], r = lm[xr + c], up = lu[xm + c], dn = ld[xm + c];
                    u0 = upsample(m, l, up, lu[xl + c]);
                    u1 = upsample(m, r, up, lu[xr + c]);
                    u2 = upsample(m, l, dn, ld[xl + c]);
                    u3 = upsample(m, r, dn, ld[xr + c]);
                }
                // Stored pixel: residual = value - prediction (mod 256).
                auto code = [&](uint8_t* px, uint8_t* slot, int pred) {
                    if constexpr (kEncode)
                        *slot = uint8_t(*px - pred);
                    else
                        *px = uint8_t(*slot + pred);
                };
                if (n == 4) {
                    int pa = 0, pb = 0, pd = 0;
                    if constexpr (kPredict) pa = predictBlockPixel(4, m, 0, u0 + u1 + u2 + u3, 4, u0);
                    code(a, &p0[c][iMulti], pa);
                    if constexpr (kPredict) pb = predictBlockPixel(4, m, *a, u1 + u2 + u3, 3, u1);
                    code(b, &p1[c][iFull], pb);
                    if constexpr (kPredict) pd = predictBlockPixel(4, m, *a + *b, u2 + u3, 2, u2);
                    code(d, &p2[c][iFull], pd);
                } else if (n == 2) {
                    // A 2x1 or 1x2 block: p00 stored, the other real pixel given by eq. (3).
                    const int uo = nx == 2 ? u1 : u2;
                    int pa = 0;
                    if constexpr (kPredict) pa = predictBlockPixel(2, m, 0, u0 + uo, 2, u0);
                    code(a, &p0[c][iMulti], pa);
                }
                // Eq. (3) generalised to n real pixels: last = n*m + eps - (sum of the others).
                if constexpr (kEncode) {
                    int sum = *a + (nx == 2 ? *b : 0) + (ny == 2 ? *d : 0) + (n == 4 ? *e : 0);
                    eps[c][epsByte] |= uint8_t((sum - n * m) << epsShift);
                } else {
                    const int ep = (eps[c][epsByte] >> epsShift) & 3;
                    bad |= unsigned(ep >= n);
                    int last = n * m + ep;
                    if (n == 4) {
                        last -= *a + *b + *d;
                        *e = uint8_t(last);
                    } else if (n == 2) {
                        last -= *a;
                        *(nx == 2 ? b : d) = uint8_t(last);
                    } else {
                        *a = uint8_t(last);
                    }
                    bad |= unsigned(last) > 255u;
                }
            }
            if (n >= 2) ++iMulti;
            if (n == 4) ++iFull;
        }
    }
    return bad == 0;
}

// Group 0: the smallest level, MED-predicted (or raw values), one plane per component.
template <bool kPredict, bool kEncode>
void walkLowest(uint8_t* pixels, int width, int height, int comps, uint8_t* payload) {
    const size_t planeBytes = size_t(width) * size_t(height);
    const size_t stride = size_t(width) * comps;
    for (int c = 0; c < comps; ++c) {
        uint8_t* plane = payload + size_t(c) * planeBytes;
        for (int y = 0; y < height; ++y) {
            uint8_t* row = pixels + size_t(y) * stride + c;
            const uint8_t* up = y > 0 ? row - stride : row;
            for (int x = 0; x < width; ++x) {
                int pred = 0;
                if constexpr (kPredict) {
                    const int w = x > 0 ? row[(x - 1) * comps] : 0;
                    const int nw = x > 0 ? up[(x - 1) * comps] : 0;
                    pred = predictMed(x, y, w, up[x * comps], nw);
                }
                uint8_t& slot = plane[size_t(y) * width + x];
                if constexpr (kEncode)
                    slot = uint8_t(row[x * comps] - pred);
                else
                    row[x * comps] = uint8_t(slot + pred);
            }
        }
    }
}

// Runtime component count to the walker's template argument.
template <bool kPredict, bool kEncode>
bool walkLevelAny(int comps, const ByteImage& low, uint8_t* cur, int w, int h, uint8_t* payload) {
    switch (comps) {
    case 1: return walkLevel<1, kPredict, kEncode>(low, cur, w, h, payload);
    case 2: return walkLevel<2, kPredict, kEncode>(low, cur, w, h, payload);
    case 3: return walkLevel<3, kPredict, kEncode>(low, cur, w, h, payload);
    default: return walkLevel<4, kPredict, kEncode>(low, cur, w, h, payload);
    }
}

}  // namespace plx::ptm::detail
