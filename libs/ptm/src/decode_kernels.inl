// The decoder's hot loop, compiled once per ISA (plx_add_isa_kernels): group k >= 1 of the
// modelled coder through the level walker with the decoder's IO.
#include "decode_io.h"
#include "walker.h"

#include "kernels.h"

namespace plx::ptm::detail::PLX_ISA_NS {

LevelCheck decodeLevel(const LevelStreams& s, const ByteImage& lower, ByteImage& level) {
    // One 32-bit entry per slot; the walker's contexts are table indices. A valid table's
    // frequencies sum to kRansTotal, so every entry is written.
    for (size_t t = 0; t < s.freqs.size(); ++t)
        buildSimdTable(s.freqs[t], s.entries + t * kRansTotal);
    DecodeIO io(s.entries, *s.familyTables, s.storedStates, s.rans, s.ransEnd,
                BitReader(s.ransEnd, s.bitsEnd));
    io.shapeEighths = s.shapeEighths;
    io.buildSmallAlphabets(s.freqs, *s.familyTables, level.channels);
    uint8_t* px = level.bytes.data();
    bool walked = false;
    switch (level.channels) {
    case 1: walked = walkLevel<1>(lower, px, level.width, level.height, io); break;
    case 2: walked = walkLevel<2>(lower, px, level.width, level.height, io); break;
    case 3: walked = walkLevel<3>(lower, px, level.width, level.height, io); break;
    default: walked = walkLevel<4>(lower, px, level.width, level.height, io); break;
    }
    if (!walked) return LevelCheck::kBadPixel;
    if (!io.finishedCleanly()) return LevelCheck::kRansUnclean;
    if (!io.bits.exact(size_t(s.bitsEnd - s.ransEnd))) return LevelCheck::kExtraBitsMismatch;
    return LevelCheck::kOk;
}

}  // namespace plx::ptm::detail::PLX_ISA_NS
