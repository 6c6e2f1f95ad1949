// The encoder's hot loop, compiled once per ISA (plx_add_isa_kernels): group k >= 1 of the
// modelled coder through the level walker with the encoder's IO.
#include "encode_io.h"
#include "walker.h"

#include "kernels.h"

namespace plx::ptm::detail::PLX_ISA_NS {

LevelTokens encodeLevel(const ByteImage& lower, const ByteImage& level, int shapeEighths,
                        LaneSymbol* symbols, uint8_t* bits) {
    EncodeIO io(symbols, bits, shapeEighths);
    // The walker takes the level's pixels mutable for decoding; encoding only reads them.
    uint8_t* px = const_cast<uint8_t*>(level.bytes.data());
    switch (level.channels) {
    case 1: walkLevel<1>(lower, px, level.width, level.height, io); break;
    case 2: walkLevel<2>(lower, px, level.width, level.height, io); break;
    case 3: walkLevel<3>(lower, px, level.width, level.height, io); break;
    default: walkLevel<4>(lower, px, level.width, level.height, io); break;
    }
    LevelTokens out;
    out.symbols = io.count;
    out.bitCount = io.bits.bitCount();
    out.bitBytes = io.bits.finish();
    return out;
}

}  // namespace plx::ptm::detail::PLX_ISA_NS
