#pragma once
// Private: the encoder's IO for the level walker (walker.h): records the tokens of each run
// with their contexts and rANS states, and writes their extra bits, into caller-owned buffers
// (the kernels allocate nothing the caller must free).

#include <cstddef>
#include <cstdint>

#include "contexts.h"
#include "rans.h"
#include "streams.h"

namespace plx::ptm::detail {
inline namespace PLX_PTM_KERNEL_NS {

struct EncodeIO {
    static constexpr bool kEncode = true;
    LaneSymbol* symbols;  // at least maxLevelSymbols of the level
    size_t count = 0;
    BitSink bits;
    int shapeEighths = 0;  // the group's mode byte (LevelRows)

    EncodeIO(LaneSymbol* symbolBuffer, uint8_t* bitBuffer, int groupShapeEighths)
        : symbols(symbolBuffer), bits(bitBuffer), shapeEighths(groupShapeEighths) {}
    CtxMap ctxMap(int c, int kind) const { return rawCtxMap(c, kind); }
    // The eps run of a component: as run<false> (the decoder's may take a faster path).
    void runEps(int, const uint16_t* ctx, int n, uint8_t* z) { run<false>(ctx, n, z); }
    // A run of n values z with contexts ctx; symbol j uses state j mod kSimdStates. kExtra: z
    // is a residual (token plus extra bits), else an eps (the token itself).
    template <bool kExtra>
    void run(const uint16_t* ctx, int n, const uint8_t* z) {
        for (int j = 0; j < n; ++j) {
            const uint8_t lane = uint8_t(j % kSimdStates);
            if constexpr (kExtra) {
                const TokenSplit s = splitToken(z[j]);
                symbols[count++] = {ctx[j], uint8_t(s.token), lane};
                if (s.bits) bits.put(s.extra, s.bits);
            } else {
                symbols[count++] = {ctx[j], z[j], lane};
            }
        }
    }
};

}  // namespace PLX_PTM_KERNEL_NS
}  // namespace plx::ptm::detail
