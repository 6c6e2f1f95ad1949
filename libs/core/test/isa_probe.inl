// A kernel compiled once per ISA tier by plx_add_isa_kernels, for the dispatch tests.
#include <cstdint>

namespace plx::test::PLX_ISA_NS {

// The tier this copy was compiled for, as the compiler sees it.
int compiledIsaLevel() {
#if defined(__AVX512VBMI__)
    return 2;
#elif defined(__AVX2__)
    return 1;
#else
    return 0;
#endif
}

int generatedIsaLevel() { return PLX_ISA_LEVEL; }

// A loop the compiler vectorises for each tier; the result must not depend on the tier.
uint64_t sumOfSquares(const uint32_t* values, int count) {
    uint64_t sum = 0;
    for (int i = 0; i < count; ++i) sum += uint64_t(values[i]) * values[i];
    return sum;
}

}  // namespace plx::test::PLX_ISA_NS
