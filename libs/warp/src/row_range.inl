// The ordered-key range of one row of floats (row_kernel.h), compiled once per ISA
// (plx_add_isa_kernels): a min and max reduction over integers, which the compiler vectorises
// (eight keys per step with AVX2; the baseline tier has no 32-bit integer min or max).

#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>

#include "row_kernel.h"

namespace plx::warp::detail::PLX_ISA_NS {

KeyRange rowKeyRange(const float* row, int width) {
    int32_t lo = std::numeric_limits<int32_t>::max(), hi = std::numeric_limits<int32_t>::min();
    for (int x = 0; x < width; ++x) {
        const auto b = std::bit_cast<int32_t>(row[x]);
        const int32_t key = b ^ int32_t(uint32_t(b >> 31) >> 1);  // orderedKey (reference.cpp)
        lo = std::min(lo, key);
        hi = std::max(hi, key);
    }
    return {lo, hi};
}

}  // namespace plx::warp::detail::PLX_ISA_NS
