// Repeat study for the PTM coder (docs/ptm-results.md, "Exact repeats"): how many 2x2 blocks of
// each stored level equal, in every component, a block already decoded before them: the block d
// pixels to the left (d even, 2..64, the d that matches most blocks of the block row) or the
// block two rows above. JPEG decodes identical 8x8 blocks of a periodic texture to identical
// pixels, noise included, and PNG's LZ77 copies them; coder 5 predicts each block from its
// neighbours and the lower level and so pays for the noise again at every repeat.
//
// Per file the default coder encodes the image; the study reports each level's repeated
// fraction and an upper bound on what a copy mode could save: every repeated block free, each
// level's group bytes spread evenly over its blocks (repeats in flat regions cost less than the
// average, and a copy mode pays for its flags, so the real saving is smaller).
// Usage: plx_ptm_repeats FILES...

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <vector>

#include <plx/core/image_io.h>
#include <plx/ptm/encoder.h>
#include <plx/ptm/format.h>
#include <plx/ptm/mip.h>

#include "forced_isa.h"

namespace {

using plx::ByteImage;

constexpr int kMaxDistance = 64;

bool sameBlock(const ByteImage& im, int x0, int y0, int x1, int y1) {
    const size_t bytes = size_t(2 * im.channels);
    return std::memcmp(im.pixel(x0, y0), im.pixel(x1, y1), bytes) == 0 &&
           std::memcmp(im.pixel(x0, y0 + 1), im.pixel(x1, y1 + 1), bytes) == 0;
}

struct Repeats {
    long blocks = 0;
    long left = 0;   // equal to the block d to the left (the row's best d)
    long above = 0;  // equal to the block two rows above
    long either = 0;
};

// The full 2x2 blocks of a level (odd edges left out).
Repeats countRepeats(const ByteImage& im) {
    Repeats r;
    for (int y = 0; y + 1 < im.height; y += 2) {
        int bestCount = -1, bestD = 2;
        for (int d = 2; d <= kMaxDistance; d += 2) {
            int n = 0;
            for (int x = d; x + 1 < im.width; x += 2) n += sameBlock(im, x, y, x - d, y);
            if (n > bestCount) {
                bestCount = n;
                bestD = d;
            }
        }
        for (int x = 0; x + 1 < im.width; x += 2) {
            const bool l = x >= bestD && sameBlock(im, x, y, x - bestD, y);
            const bool u = y >= 2 && sameBlock(im, x, y, x, y - 2);
            ++r.blocks;
            r.left += l;
            r.above += u;
            r.either += l || u;
        }
    }
    return r;
}

}  // namespace

int main(int argc, char** argv) {
    if (plx::mains::refuseUnknownForcedIsa(argv[0])) return 2;
    if (argc < 2) {
        std::fprintf(stderr, "usage: plx_ptm_repeats FILES...\n");
        return 2;
    }
    double ptmSum = 0, boundSum = 0;
    Repeats baseSum;
    int used = 0;
    std::printf(
        "| file | base-level blocks repeated (left / above / either) | PTM bytes | "
        "bound: repeats free |\n| --- | ---: | ---: | ---: |\n");
    for (int i = 1; i < argc; ++i) {
        auto img = plx::readImage(argv[i]);
        if (!img) {
            std::fprintf(stderr, "%s: %s\n", argv[i], img.status().message().c_str());
            continue;
        }
        auto file = plx::ptm::encode(*img);
        if (!file) {
            std::fprintf(stderr, "%s: %s\n", argv[i], file.status().message().c_str());
            continue;
        }
        auto header = plx::ptm::parseHeader(*file);
        if (!header) {
            std::fprintf(stderr, "%s: %s\n", argv[i], header.status().message().c_str());
            return 1;
        }
        const int count = header->levelCount;
        const auto chain = plx::ptm::buildMipChain(*img, count);
        double saved = 0;
        Repeats base;
        for (int k = 1; k < count; ++k) {  // level 0 is stored whole
            const Repeats r = countRepeats(chain[size_t(k)]);
            if (r.blocks > 0)
                saved +=
                    double(header->groups[size_t(k)].size) * double(r.either) / double(r.blocks);
            if (k == count - 1) base = r;
        }
        ++used;
        ptmSum += double(file->size());
        boundSum += double(file->size()) - saved;
        baseSum.blocks += base.blocks;
        baseSum.left += base.left;
        baseSum.above += base.above;
        baseSum.either += base.either;
        auto pct = [](long n, long d) { return d ? 100.0 * double(n) / double(d) : 0.0; };
        const char* name = std::strrchr(argv[i], '/') ? std::strrchr(argv[i], '/') + 1 : argv[i];
        std::printf("| %s | %.1f%% / %.1f%% / %.1f%% | %zu | %.0f |\n", name,
                    pct(base.left, base.blocks), pct(base.above, base.blocks),
                    pct(base.either, base.blocks), file->size(), double(file->size()) - saved);
    }
    std::printf(
        "\n%d images: PTM %.0f bytes; with every repeated block free at most %.0f bytes "
        "(%.4fx); base-level blocks repeated %.1f%%\n",
        used, ptmSum, boundSum, ptmSum > 0 ? boundSum / ptmSum : 0.0,
        baseSum.blocks ? 100.0 * double(baseSum.either) / double(baseSum.blocks) : 0.0);
    return used > 0 ? 0 : 1;
}
