#pragma once
// PTM encoding (Marvie & Bouatouch section 4): mip chain by eq. (1), per level the 2-bit residual
// errors and the partial level (3 of 4 pixels per block), entropy coded, written smallest level
// first with a level index (docs/ptm-format.md).

#include <cstdint>
#include <vector>

#include <plx/core/image.h>
#include <plx/core/status.h>
#include <plx/ptm/format.h>

namespace plx::ptm {

struct EncodeConfig {
    // The smallest stored level is the first of the chain whose larger side is <= this (1 keeps
    // the chain down to 1x1). Any resolution is allowed (paper 4.3); clients rebuild the levels
    // below it with eq. (1). Must be >= 1.
    int lowestMaxSide = 1;
    Coder coder = Coder::kRans;
    // Coder kRans: the weight of the detail above in the upper pixels' shapes, in eighths (0..4),
    // for every level; -1 (the default) tries 4, 3, 2 and 0 per level and keeps the group with
    // the smallest estimated size, which encodes about three times slower.
    int shapeEighths = -1;
};

// Number of stored levels for an image of w x h under `config` (>= 1).
// Preconditions: w, h >= 1; config.lowestMaxSide >= 1.
int storedLevelCount(int width, int height, const EncodeConfig& config);

// Encodes an 8-bit image with 1-4 channels to PTM bytes. Errors: empty or oversized image,
// channel count outside 1..4, config out of range.
Result<std::vector<uint8_t>> encode(const ByteImage& image, const EncodeConfig& config = {});

}  // namespace plx::ptm
