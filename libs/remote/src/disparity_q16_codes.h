#pragma once
// The codes of the q16 disparity payload (docs/remote-protocol.md, "Disparity, q16"), shared by
// the codec's per-ISA kernels (disparity_kernels.inl) and its pixel-by-pixel reference. The kernels
// include this header once per ISA, so its inline functions sit in a namespace named after the
// including translation unit's ISA: otherwise the linker could keep one ISA's copy for all
// callers (an AVX-512 copy for a CPU without it).

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "payloads.h"

#if defined(PLX_ISA_NS)
#define PLX_Q16_CODES_NS PLX_ISA_NS
#else
#define PLX_Q16_CODES_NS isa_baseline
#endif

namespace plx::remote::q16 {
inline namespace PLX_Q16_CODES_NS {

// 65535 codes for drawn pixels: q = 1 + round((d - dmin) / step), 0 = nothing drawn.
inline constexpr double kSteps = 65534.0;

inline double quantStep(DisparityRange r) {
    return (double(r.dmax) - double(r.dmin)) / kSteps;
}

// 1 / quantStep, what the encoders multiply by; 0 where the view has one value drawn (every drawn
// pixel code 1) or none.
inline double inverseQuantStep(DisparityRange r) {
    const double step = quantStep(r);
    return step > 0.0 ? 1.0 / step : 0.0;
}

// q16-packed: the symbol bytes of one row, four pixels a byte.
inline size_t packedRowBytes(int width) {
    return (size_t(width) + 3) / 4;
}

// The prediction of q[x] from the row so far (x >= 1) or the row above's first code (x == 0).
// Next to an empty pixel (q = 0) the plane predictor would extrapolate from "infinitely far", so
// the left neighbour is used alone.
inline int predict(const uint16_t* row, int x, int aboveFirst) {
    if (x == 0) return aboveFirst;
    const int a = row[x - 1];
    if (x == 1) return a;
    const int b = row[x - 2];
    if (a == 0 || b == 0) return a;
    return std::clamp(2 * a - b, 0, 65535);
}

inline uint16_t zigzag(int residual) {
    const auto r = int16_t(uint16_t(residual));  // (q - pred) mod 2^16, as signed
    return uint16_t((uint16_t(r) << 1) ^ uint16_t(r >> 15));
}

inline int unzigzag(uint16_t z) {
    return int(z >> 1) ^ -int(z & 1);
}

}  // namespace PLX_Q16_CODES_NS
}  // namespace plx::remote::q16
