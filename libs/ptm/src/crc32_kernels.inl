// CRC-32 (reflected polynomial 0xEDB88320), compiled once per ISA (plx_add_isa_kernels):
// slicing by 8 bytes (about 8x a bytewise table) in the scalar entry and, in the avx2 and avx512
// entries, folding of 64-byte blocks by carry-less multiplication with a Barrett reduction
// (Gopal et al., "Fast CRC Computation for Generic Polynomials Using PCLMULQDQ Instruction",
// Intel 2009; the constants are those of the bit-reflected CRC-32). PCLMULQDQ is not part of
// x86-64-v3, so crcClmul enables it by itself: every CPU with AVX2 has it (Intel since
// Westmere, AMD since Bulldozer).
#include <cstddef>
#include <cstdint>

#if PLX_ISA_LEVEL >= 1
#include <immintrin.h>
#endif

#include "kernels.h"

namespace plx::ptm::detail::PLX_ISA_NS {
namespace {

// The eight slicing tables: t[s][b] is the CRC of byte b followed by s zero bytes.
struct Tables {
    uint32_t t[8][256] = {};
    constexpr uint32_t* operator[](int s) { return t[s]; }
    constexpr const uint32_t* operator[](int s) const { return t[s]; }
};

constexpr Tables makeTables() {
    Tables t{};
    for (uint32_t i = 0; i < 256; ++i) {
        uint32_t c = i;
        for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        t[0][i] = c;
    }
    for (int s = 1; s < 8; ++s)
        for (uint32_t i = 0; i < 256; ++i) t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xFF];
    return t;
}

constexpr Tables kTables = makeTables();

// Continues the inverted CRC register c over n bytes by table look-ups.
uint32_t crcTables(const uint8_t* p, size_t n, uint32_t c) {
    while (n >= 8) {
        uint32_t lo = c ^ (uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 |
                           uint32_t(p[3]) << 24);
        uint32_t hi = uint32_t(p[4]) | uint32_t(p[5]) << 8 | uint32_t(p[6]) << 16 |
                      uint32_t(p[7]) << 24;
        c = kTables[7][lo & 0xFF] ^ kTables[6][(lo >> 8) & 0xFF] ^ kTables[5][(lo >> 16) & 0xFF] ^
            kTables[4][lo >> 24] ^ kTables[3][hi & 0xFF] ^ kTables[2][(hi >> 8) & 0xFF] ^
            kTables[1][(hi >> 16) & 0xFF] ^ kTables[0][hi >> 24];
        p += 8;
        n -= 8;
    }
    while (n--) c = kTables[0][(c ^ *p++) & 0xFF] ^ (c >> 8);
    return c;
}

#if PLX_ISA_LEVEL >= 1
// Continues the inverted CRC register c over n bytes. Precondition: n >= 64, n % 16 == 0.
// Four 128-bit accumulators fold 64 bytes per step (x^(512+-32) constants), are folded into one
// (x^(128+-32)), 16-byte blocks follow, then 128 -> 64 bits and the Barrett reduction to 32.
// One fold: x times the constant pair k (x^(n+-32) mod P), plus the next data block.
__attribute__((target("pclmul"))) __m128i fold(__m128i x, __m128i k, __m128i data) {
    const __m128i lo = _mm_clmulepi64_si128(x, k, 0x00);
    const __m128i hi = _mm_clmulepi64_si128(x, k, 0x11);
    return _mm_xor_si128(_mm_xor_si128(hi, lo), data);
}

__attribute__((target("pclmul"))) uint32_t crcClmul(const uint8_t* p, size_t n, uint32_t c) {
    auto load = [](const uint8_t* q) {
        return _mm_loadu_si128(reinterpret_cast<const __m128i*>(q));
    };
    const __m128i k1k2 = _mm_set_epi64x(0x01c6e41596, 0x0154442bd4);
    const __m128i k3k4 = _mm_set_epi64x(0x00ccaa009e, 0x01751997d0);
    const __m128i k5k0 = _mm_set_epi64x(0, 0x0163cd6124);
    const __m128i poly = _mm_set_epi64x(0x01f7011641, 0x01db710641);
    __m128i x1 = _mm_xor_si128(load(p), _mm_cvtsi32_si128(int(c)));
    __m128i x2 = load(p + 16), x3 = load(p + 32), x4 = load(p + 48);
    p += 64;
    n -= 64;
    for (; n >= 64; p += 64, n -= 64) {
        x1 = fold(x1, k1k2, load(p));
        x2 = fold(x2, k1k2, load(p + 16));
        x3 = fold(x3, k1k2, load(p + 32));
        x4 = fold(x4, k1k2, load(p + 48));
    }
    x1 = fold(x1, k3k4, x2);
    x1 = fold(x1, k3k4, x3);
    x1 = fold(x1, k3k4, x4);
    for (; n >= 16; p += 16, n -= 16) x1 = fold(x1, k3k4, load(p));
    // 128 -> 64 bits.
    const __m128i mask32 = _mm_setr_epi32(~0, 0, ~0, 0);
    x1 = _mm_xor_si128(_mm_srli_si128(x1, 8), _mm_clmulepi64_si128(x1, k3k4, 0x10));
    x1 = _mm_xor_si128(_mm_clmulepi64_si128(_mm_and_si128(x1, mask32), k5k0, 0x00),
                       _mm_srli_si128(x1, 4));
    // Barrett reduction to 32 bits.
    __m128i t = _mm_clmulepi64_si128(_mm_and_si128(x1, mask32), poly, 0x10);
    t = _mm_clmulepi64_si128(_mm_and_si128(t, mask32), poly, 0x00);
    return uint32_t(_mm_extract_epi32(_mm_xor_si128(x1, t), 1));
}
#endif

}  // namespace

uint32_t crc32Update(const uint8_t* p, size_t n, uint32_t c) {
#if PLX_ISA_LEVEL >= 1
    if (n >= 64) {
        const size_t blocks = n & ~size_t(15);
        c = crcClmul(p, blocks, c);
        p += blocks;
        n -= blocks;
    }
#endif
    return crcTables(p, n, c);
}

}  // namespace plx::ptm::detail::PLX_ISA_NS
