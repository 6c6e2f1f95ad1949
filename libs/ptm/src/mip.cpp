#include <algorithm>

#include <plx/core/check.h>
#include <plx/ptm/mip.h>

namespace plx::ptm {

int fullChainLength(int width, int height) {
    PLX_CHECK(width >= 1 && height >= 1);
    int count = 1;
    LevelSize s{width, height};
    while (s.width > 1 || s.height > 1) {
        s = lowerLevelSize(s);
        ++count;
    }
    return count;
}

std::vector<LevelSize> levelSizes(int width, int height, int count) {
    PLX_CHECK(count >= 1 && count <= fullChainLength(width, height));
    std::vector<LevelSize> sizes(static_cast<size_t>(count));
    LevelSize s{width, height};
    for (int k = count - 1; k >= 0; --k) {
        sizes[size_t(k)] = s;
        s = lowerLevelSize(s);
    }
    return sizes;
}

ByteImage boxReduce(const ByteImage& level) {
    PLX_CHECK(level.channels >= 1 && level.channels <= 4 && level.width >= 1 && level.height >= 1);
    PLX_CHECK(level.bytes.size() == level.rowBytes() * size_t(level.height));
    LevelSize low = lowerLevelSize({level.width, level.height});
    const int c = level.channels;
    ByteImage out{low.width, low.height, c, {}};
    out.bytes.resize(out.rowBytes() * size_t(low.height));
    for (int by = 0; by < low.height; ++by) {
        // Rows of the block; an odd last row is replicated (eq. 1 on the padded level).
        const int y0 = 2 * by, y1 = std::min(2 * by + 1, level.height - 1);
        const int rows = y1 > y0 ? 2 : 1;
        const uint8_t* r0 = level.bytes.data() + size_t(y0) * level.rowBytes();
        const uint8_t* r1 = level.bytes.data() + size_t(y1) * level.rowBytes();
        uint8_t* dst = out.bytes.data() + size_t(by) * out.rowBytes();
        for (int bx = 0; bx < low.width; ++bx) {
            const int x0 = 2 * bx, x1 = std::min(2 * bx + 1, level.width - 1);
            const int n = rows * (x1 > x0 ? 2 : 1);
            for (int k = 0; k < c; ++k) {
                int sum = r0[x0 * c + k];
                if (x1 > x0) sum += r0[x1 * c + k];
                if (rows == 2) {
                    sum += r1[x0 * c + k];
                    if (x1 > x0) sum += r1[x1 * c + k];
                }
                // n is 1, 2 or 4; the quotient is eq. (1)'s integer part (shift by 2 for n = 4).
                dst[bx * c + k] = uint8_t(sum / n);
            }
        }
    }
    return out;
}

std::vector<ByteImage> buildMipChain(const ByteImage& base, int count) {
    PLX_CHECK(count >= 1 && count <= fullChainLength(base.width, base.height));
    std::vector<ByteImage> chain(static_cast<size_t>(count));
    chain[size_t(count - 1)] = base;
    for (int k = count - 2; k >= 0; --k) chain[size_t(k)] = boxReduce(chain[size_t(k + 1)]);
    return chain;
}

}  // namespace plx::ptm
