#pragma once
// Mip chains by the 2x2 box filter F of Marvie & Bouatouch eq. (1), with the odd-size rule of
// docs/ptm-format.md: a level of size w x h has a lower level of size ceil(w/2) x ceil(h/2); a
// block on an odd last row or column holds n = 2 (or 1) real pixels and its parent is
// floor(sum / n), which equals eq. (1) on the level padded by replicating its last row/column.

#include <vector>

#include <plx/core/image.h>

namespace plx::ptm {

struct LevelSize {
    int width = 0;
    int height = 0;
    friend bool operator==(const LevelSize&, const LevelSize&) = default;
};

// Size of the level below: ceil(w/2) x ceil(h/2). Precondition: w, h >= 1.
inline LevelSize lowerLevelSize(LevelSize s) { return {(s.width + 1) / 2, (s.height + 1) / 2}; }

// Number of levels from w x h down to 1x1 inclusive (1 for a 1x1 image). Precondition: w, h >= 1.
int fullChainLength(int width, int height);

// Sizes of `count` levels, index 0 the smallest and count - 1 the base (width x height).
// Preconditions: w, h >= 1; 1 <= count <= fullChainLength(w, h).
std::vector<LevelSize> levelSizes(int width, int height, int count);

// Applies F (eq. 1, odd-size rule) to every component: the next lower mip level.
// Preconditions: level has 1-4 channels, width and height >= 1, bytes sized to match.
ByteImage boxReduce(const ByteImage& level);

// The mip chain of `count` levels, index 0 the smallest and count - 1 a copy of `base`.
// Preconditions: as boxReduce; 1 <= count <= fullChainLength(base.width, base.height).
std::vector<ByteImage> buildMipChain(const ByteImage& base, int count);

}  // namespace plx::ptm
