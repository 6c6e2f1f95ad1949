// Predictor study for the PTM coder (docs/ptm-results.md, "Choosing the predictor"): for each
// candidate spatial predictor of the partial-level pixels, the zstd-compressed size of the
// residual planes of every level over a set of textures. Encoder-side only (every neighbour is
// known); it ranks candidates, the chosen one is then implemented in the codec and verified by
// round trips. Usage: plx_ptm_study [zstdLevel] [maxFiles] FILES...

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <zstd.h>

#include <plx/core/image_io.h>
#include <plx/ptm/mip.h>

#include "forced_isa.h"

namespace {

using plx::ByteImage;

int med(int a, int b, int c) {
    int mx = std::max(a, b), mn = std::min(a, b);
    return c >= mx ? mn : (c <= mn ? mx : a + b - c);
}

struct Level {
    const ByteImage* cur;
    const ByteImage* low;
    int at(const ByteImage* im, int x, int y, int k) const { return im->pixel(x, y)[k]; }
    // Bilinear upsample of the lower level at pixel (x, y) of this level (weights 9,3,3,1 / 16).
    int up(int x, int y, int k) const {
        int px = x / 2, py = y / 2;
        int qx = std::clamp(x % 2 ? px + 1 : px - 1, 0, low->width - 1);
        int qy = std::clamp(y % 2 ? py + 1 : py - 1, 0, low->height - 1);
        return (9 * at(low, px, py, k) + 3 * at(low, qx, py, k) + 3 * at(low, px, qy, k) +
                at(low, qx, qy, k) + 8) >> 4;
    }
};

int predict(int variant, const Level& L, int x, int y, int k) {
    const ByteImage* c = L.cur;
    int u = L.up(x, y, k);
    int m = L.at(L.low, x / 2, y / 2, k);
    bool hw = x > 0, hn = y > 0;
    int W = hw ? L.at(c, x - 1, y, k) : u, N = hn ? L.at(c, x, y - 1, k) : u;
    int NW = hw && hn ? L.at(c, x - 1, y - 1, k) : u;
    int dW = hw ? W - L.up(x - 1, y, k) : 0, dN = hn ? N - L.up(x, y - 1, k) : 0;
    int dNW = hw && hn ? NW - L.up(x - 1, y - 1, k) : 0;
    switch (variant) {
    case 0: return med(W, N, NW);
    case 1: return m;
    case 2: return u;
    case 3: return u + med(dW, dN, dNW);
    case 4: return u + ((dW + dN) >> 1);
    case 5: return (med(W, N, NW) + u + 1) >> 1;
    case 6: {
        // Paeth on the detail.
        int p = dW + dN - dNW, pa = std::abs(p - dW), pb = std::abs(p - dN),
            pc = std::abs(p - dNW);
        int d = (pa <= pb && pa <= pc) ? dW : (pb <= pc ? dN : dNW);
        return u + d;
    }
    default: {
        // Constrained: the remaining pixels of the block sum to about 4m + 1.5 minus the known
        // ones; spread that sum by the bilinear shape U.
        int bx = x & ~1, by = y & ~1, x1 = std::min(bx + 1, c->width - 1),
            y1 = std::min(by + 1, c->height - 1);
        int pos = (x - bx) + 2 * (y - by);
        int n = (x1 - bx + 1) * (y1 - by + 1);
        int known = 0, sumU = 0, rem = 0, idx = 0;
        for (int yy = by; yy <= y1; ++yy)
            for (int xx = bx; xx <= x1; ++xx, ++idx) {
                int ip = (xx - bx) + 2 * (yy - by);
                if (ip < pos) known += L.at(c, xx, yy, k);
                else sumU += L.up(xx, yy, k), ++rem;
            }
        (void)idx;
        int target = 4 * n * m + 2 * n - 4 * known;  // x4 fixed point of the remaining sum
        int corr = (target - 4 * sumU) / (4 * rem);
        int p = u + corr;
        if (variant == 8) p = (p + u + ((dW + dN) >> 1) + 1) >> 1;
        return std::clamp(p, 0, 255);
    }
    }
}

const char* kNames[] = {"MED(W,N,NW)", "parent m", "bilinear U", "U + MED(detail)",
                        "U + avg(dW,dN)", "(MED + U)/2", "U + Paeth(detail)",
                        "U + block-sum correction", "avg(v7, v4)"};
constexpr int kVariants = 9;

size_t zsize(const std::vector<uint8_t>& raw, int level) {
    std::vector<uint8_t> out(ZSTD_compressBound(raw.size()));
    return ZSTD_compress(out.data(), out.size(), raw.data(), raw.size(), level);
}

// Bytes of the whole file coded with `variant`, colour decorrelation on or off.
size_t codedSize(const std::vector<ByteImage>& chain, int variant, bool decorrelate, int zl) {
    size_t total = chain[0].bytes.size();
    const int C = chain[0].channels;
    for (size_t n = 1; n < chain.size(); ++n) {
        const ByteImage& cur = chain[n];
        const ByteImage& low = chain[n - 1];
        Level L{&cur, &low};
        std::vector<std::vector<uint8_t>> eps(C), planes(3 * C * 8);
        for (int by = 0; by < low.height; ++by)
            for (int bx = 0; bx < low.width; ++bx) {
                int x1 = std::min(2 * bx + 1, cur.width - 1), y1 = std::min(2 * by + 1,
                                                                           cur.height - 1);
                int xs[3] = {2 * bx, x1, 2 * bx}, ys[3] = {2 * by, 2 * by, y1};
                int nx = x1 > 2 * bx ? 2 : 1, ny = y1 > 2 * by ? 2 : 1;
                int stored = nx * ny - 1;
                int posList[3] = {0, 1, 2};
                if (nx == 1) posList[0] = 0, posList[1] = 2;  // 1x2 block: p00 stored only
                for (int k = 0; k < C; ++k) {
                    int sum = 0;
                    for (int yy = 2 * by; yy <= y1; ++yy)
                        for (int xx = 2 * bx; xx <= x1; ++xx) sum += cur.pixel(xx, yy)[k];
                    eps[k].push_back(uint8_t(sum % (nx * ny)));
                }
                for (int s = 0; s < stored; ++s) {
                    int pos = posList[s];
                    int x = xs[pos], y = ys[pos];
                    int r[4];
                    for (int k = 0; k < C; ++k)
                        r[k] = cur.pixel(x, y)[k] - predict(variant, L, x, y, k);
                    if (decorrelate && C >= 3) {
                        r[0] -= r[1];
                        r[2] -= r[1];
                    }
                    int ctx = 0;
                    if (getenv("PTM_CTX")) {
                        int a = 0;
                        int px = x / 2, py = y / 2;
                        for (int k = 0; k < C; ++k) {
                            int m0 = low.pixel(px, py)[k];
                            a += std::abs(m0 - low.pixel(std::max(px - 1, 0), py)[k]) +
                                 std::abs(m0 - low.pixel(std::min(px + 1, low.width - 1), py)[k]) +
                                 std::abs(m0 - low.pixel(px, std::max(py - 1, 0))[k]) +
                                 std::abs(m0 - low.pixel(px, std::min(py + 1, low.height - 1))[k]);
                        }
                        a = a / C;
                        static const int th[7] = {3, 6, 10, 15, 22, 32, 48};
                        while (ctx < 7 && a >= th[ctx]) ++ctx;
                    }
                    for (int k = 0; k < C; ++k)
                        planes[(pos * C + k) * 8 + ctx].push_back(uint8_t(r[k]));
                }
            }
        std::vector<uint8_t> all;
        if (getenv("PTM_STUDY_VERBOSE") && n + 1 == chain.size()) {
            std::vector<uint8_t> e0;
            for (auto& e : eps) e0.insert(e0.end(), e.begin(), e.end());
            std::printf("  top eps raw %zu z %zu |", e0.size(), zsize(e0, zl));
            for (auto& p : planes) std::printf(" %zu", zsize(p, zl));
            std::printf("\n");
        }
        for (auto& e : eps) {
            for (size_t i = 0; i < e.size(); i += 4) {
                uint8_t b = 0;
                for (size_t j = 0; j < 4 && i + j < e.size(); ++j) b |= uint8_t(e[i + j] << (2 * j));
                all.push_back(b);
            }
        }
        for (auto& p : planes) all.insert(all.end(), p.begin(), p.end());
        total += zsize(all, zl);
    }
    return total;
}

}  // namespace

int main(int argc, char** argv) {
    if (plx::mains::refuseUnknownForcedIsa(argv[0])) return 2;
    if (argc < 4) {
        std::fprintf(stderr, "usage: plx_ptm_study ZSTD_LEVEL MAX_FILES FILES...\n");
        return 2;
    }
    int zl = std::atoi(argv[1]);
    int maxFiles = std::atoi(argv[2]);
    std::vector<size_t> sums(2 * kVariants, 0);
    size_t pngSum = 0, rawSum = 0;
    int used = 0;
    for (int i = 3; i < argc && used < maxFiles; ++i) {
        auto img = plx::readImage(argv[i]);
        if (!img) continue;
        ++used;
        auto chain = plx::ptm::buildMipChain(*img, plx::ptm::fullChainLength(img->width,
                                                                             img->height));
        rawSum += img->bytes.size();
        pngSum += plx::encodePng(*img, 9)->size();
        size_t png = plx::encodePng(*img, 9)->size();
        for (int v = 0; v < kVariants; ++v)
            for (int d = 0; d < 2; ++d) {
                size_t s = codedSize(chain, v, d, zl);
                sums[size_t(2 * v + d)] += s;
                if (getenv("PTM_STUDY_VERBOSE"))
                    std::printf("%s c%d v%d d%d: %zu png %zu\n", argv[i], img->channels, v, d, s,
                                png);
            }
    }
    std::printf("%d images, base raw %zu bytes, PNG level 9 %zu bytes\n", used, rawSum, pngSum);
    std::printf("| predictor | colour | bytes | vs PNG-9 |\n| --- | --- | ---: | ---: |\n");
    for (int v = 0; v < kVariants; ++v)
        for (int d = 0; d < 2; ++d)
            std::printf("| %s | %s | %zu | %.3f |\n", kNames[v], d ? "R-G, B-G" : "none",
                        sums[size_t(2 * v + d)], double(sums[size_t(2 * v + d)]) / pngSum);
    return 0;
}
