#pragma once
// Private: coder kRaw (and the modelled coder's stored groups): the plane layout of a level group
// and the walker that both the encoder (pixels to planes) and the decoder (planes to pixels)
// run, so that the two cannot disagree.
//
// Group k >= 1 (level size w x h, lower level lw x lh = ceil(w/2) x ceil(h/2), C components)
// holds, in order: for each component the packed residual-error plane (Marvie eq. 3's epsilon,
// 2 bits per block, 4 blocks per byte, first block in the low bits); then the partial level as
// 3*C pixel planes, position-major: p00 of every block with n >= 2 real pixels (component 0, 1,
// ...), then p10 of every full 2x2 block, then p01 of every full block. The last real pixel of
// each block (p11 for a full block) is not stored: eq. (3) gives it. Group 0 holds C planes of
// the whole smallest level.

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

// Walks level `cur` block by block in raster order. Encode: reads cur, writes payload planes.
// Decode: reads payload planes, writes cur; returns false if the payload is inconsistent (an
// epsilon >= n or a reconstructed pixel outside 0..255). low is the complete lower level.
template <int C, bool kEncode>
bool walkRawLevel(const ByteImage& low, uint8_t* cur, int width, int height, uint8_t* payload) {
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
        for (int bx = 0; bx < low.width; ++bx, ++block) {
            const int x0 = 2 * bx, x1 = std::min(x0 + 1, width - 1);
            const int nx = x1 > x0 ? 2 : 1, ny = y1 > y0 ? 2 : 1, n = nx * ny;
            const size_t xm = size_t(bx) * C;
            const size_t epsByte = block >> 2;
            const int epsShift = int(block & 3) * 2;
            for (int c = 0; c < C; ++c) {
                const int m = lm[xm + c];
                uint8_t* a = r0 + size_t(x0) * C + c;  // p00
                uint8_t* b = r0 + size_t(x1) * C + c;  // p10 (== p00 when nx == 1)
                uint8_t* d = r1 + size_t(x0) * C + c;  // p01 (== p00 when ny == 1)
                uint8_t* e = r1 + size_t(x1) * C + c;  // p11, the last real pixel
                // A stored pixel: copied to or from its plane.
                auto code = [&](uint8_t* px, uint8_t* slot) {
                    if constexpr (kEncode)
                        *slot = *px;
                    else
                        *px = *slot;
                };
                if (n == 4) {
                    code(a, &p0[c][iMulti]);
                    code(b, &p1[c][iFull]);
                    code(d, &p2[c][iFull]);
                } else if (n == 2) {  // a 2x1 or 1x2 block: the other real pixel by eq. (3)
                    code(a, &p0[c][iMulti]);
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

// Group 0: the smallest level, one plane per component.
template <bool kEncode>
void walkRawLowest(uint8_t* pixels, int width, int height, int comps, uint8_t* payload) {
    const size_t planeBytes = size_t(width) * size_t(height);
    for (int c = 0; c < comps; ++c) {
        uint8_t* plane = payload + size_t(c) * planeBytes;
        for (size_t i = 0; i < planeBytes; ++i) {
            uint8_t& px = pixels[i * size_t(comps) + size_t(c)];
            if constexpr (kEncode)
                plane[i] = px;
            else
                px = plane[i];
        }
    }
}

// Runtime component count to the walker's template argument.
template <bool kEncode>
bool walkRawLevelAny(int comps, const ByteImage& low, uint8_t* cur, int w, int h,
                     uint8_t* payload) {
    switch (comps) {
    case 1: return walkRawLevel<1, kEncode>(low, cur, w, h, payload);
    case 2: return walkRawLevel<2, kEncode>(low, cur, w, h, payload);
    case 3: return walkRawLevel<3, kEncode>(low, cur, w, h, payload);
    default: return walkRawLevel<4, kEncode>(low, cur, w, h, payload);
    }
}

}  // namespace plx::ptm::detail
