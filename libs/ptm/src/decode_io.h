#pragma once
// Private: the decoder's IO for the level walker (walker.h): kSimdStates interleaved rANS
// states (docs/ptm-format.md, "Entropy coding"). Symbol j of a run uses state j mod 32 and the
// renormalisation words are read in symbol order, so that a round of 32 symbols decodes as
// vectors of states:
//
// - one 32-bit decode entry per (table, slot): frequency, slot - cumulative start and token, so
//   a symbol is one gather, a multiply and an add;
// - AVX2: four vectors of eight states; the states that fall below 2^16 take the next words in
//   lane order (a movemask gives the lanes, a 256-entry table of packed lane-to-word
//   permutations moves the words loaded at the stream pointer into them);
// - AVX-512: two vectors of sixteen states (vpgatherdd, vpexpandd for the words), and the eps
//   runs, whose tables hold tokens 0..3, find their symbols without a table load;
// - the extra bits of a run's tokens are read afterwards, sixteen (AVX2) or 32 (AVX-512 VBMI)
//   tokens per vector step.
//
// A scalar decoder of the same stream handles the tail of a run (fewer than 32 symbols), the last
// 64 bytes of the stream (bounds-checked reads) and the scalar ISA.

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <cstring>
#include <span>

#include "contexts.h"
#include "lanes.h"
#include "rans.h"
#include "streams.h"

namespace plx::ptm::detail {
inline namespace PLX_PTM_KERNEL_NS {

// Fills the kRansTotal entries of one table from freq (sum kRansTotal, or all zero: then every
// slot decodes token 0 with frequency kRansTotal, which keeps the state and is caught by the
// final state check). A kernel: it writes 16 KB per table, for every table of every group.
inline void buildSimdTable(const std::array<uint16_t, kTokenCount>& freq, uint32_t* entries) {
    uint32_t cum = 0;
    for (int s = 0; s < kTokenCount; ++s) {
        const uint32_t f = freq[size_t(s)];
        const uint32_t head = f | uint32_t(s) << kEntryTokenShift;
        uint32_t* e = entries + cum;  // a valid table has cum + f <= kRansTotal (readTable)
        for (uint32_t i = 0; i < f; ++i) e[i] = head | i << kEntryBiasShift;
        cum += f;
    }
    if (cum == 0)  // empty table: token 0 everywhere, the state unchanged
        for (uint32_t i = 0; i < kRansTotal; ++i) entries[i] = kRansTotal | i << kEntryBiasShift;
}

// Packed lane-to-word permutations for the renormalisation: for a mask of the lanes that read a
// word, 3 bits per lane (lane l at bits 3l) giving the index of its word among the words read
// (the number of reading lanes below it); 0 for lanes that read nothing.
struct RenormPermutations {
    std::array<uint32_t, 256> packed{};
    constexpr RenormPermutations() {
        for (unsigned m = 0; m < 256; ++m) {
            uint32_t v = 0;
            unsigned k = 0;
            for (unsigned l = 0; l < 8; ++l)
                if (m >> l & 1) v |= (k++) << (3 * l);
            packed[m] = v;
        }
    }
};
inline constexpr RenormPermutations kRenormPerm{};

#if defined(__AVX2__)
// Byte lookups of the extra-bit decode (rans.h, TokenTables), indexed by the low 4 bits of a
// token: for tokens 16..23 (index t - 16) their extra-bit counts and bases (tokens below 16 have
// none and are their own value), and per shift s in 0..7 the multiplier 2^(8 - s) as low and
// high byte, per count n the mask 2^n - 1.
struct ExtraBitLuts {
    alignas(16) uint8_t bits[16]{}, base[16]{}, mulLo[16]{}, mulHi[16]{}, mask[16]{};
    constexpr ExtraBitLuts() {
        for (int t = 16; t < kTokenCount; ++t) {
            bits[t - 16] = kTokens.bits[size_t(t)];
            base[t - 16] = uint8_t(kTokens.base[size_t(t)]);
        }
        for (int k = 0; k < 8; ++k) {
            mulLo[k] = uint8_t((256 >> k) & 255);
            mulHi[k] = uint8_t(256 >> k >> 8);
            mask[k] = uint8_t((1 << k) - 1);
        }
    }
};
inline constexpr ExtraBitLuts kExtraLuts{};

// The values of tokens z[0..16k) from their extra bits, sixteen tokens per step without a
// branch: the bit offsets are a byte-wise prefix sum of the counts (sixteen tokens hold at most
// 96 bits, so one 16-byte window of the stream holds them all), each token's two bytes come from
// the window by a byte shuffle, the shift by its offset is a 16-bit multiply. Reads the stream of
// `bits` from its position on while 16 bytes remain there, then moves it past the bits taken.
// Returns the number of tokens done. Bit-exact with the scalar take() loop.
inline int extraBitsAvx2(uint8_t* z, int n, BitReader& bits) {
    auto lut = [](const uint8_t* t) { return _mm_load_si128(reinterpret_cast<const __m128i*>(t)); };
    const __m128i bitsLut = lut(kExtraLuts.bits), baseLut = lut(kExtraLuts.base);
    const __m128i mulLo = lut(kExtraLuts.mulLo), mulHi = lut(kExtraLuts.mulHi);
    const __m128i maskLut = lut(kExtraLuts.mask);
    const __m128i fifteen = _mm_set1_epi8(15), seven = _mm_set1_epi8(7);
    const __m128i one = _mm_set1_epi8(1), low5 = _mm_set1_epi8(0x1F);
    const uint8_t* stream = bits.streamBegin();
    const size_t size = bits.streamBytes();
    uint64_t pos = bits.position();
    int i = 0;
    for (; i + 16 <= n && pos / 8 + 16 <= size; i += 16) {
        const __m128i t = _mm_loadu_si128(reinterpret_cast<const __m128i*>(z + i));
        const __m128i big = _mm_cmpgt_epi8(t, fifteen);  // tokens with extra bits
        const __m128i count = _mm_and_si128(_mm_shuffle_epi8(bitsLut, t), big);
        const __m128i base = _mm_blendv_epi8(t, _mm_shuffle_epi8(baseLut, t), big);
        // Inclusive prefix sum of the counts, then each token's offset from the window's bit 0.
        __m128i sum = _mm_add_epi8(count, _mm_slli_si128(count, 1));
        sum = _mm_add_epi8(sum, _mm_slli_si128(sum, 2));
        sum = _mm_add_epi8(sum, _mm_slli_si128(sum, 4));
        sum = _mm_add_epi8(sum, _mm_slli_si128(sum, 8));
        const __m128i off = _mm_add_epi8(_mm_sub_epi8(sum, count), _mm_set1_epi8(int8_t(pos % 8)));
        const __m128i byteAt = _mm_and_si128(_mm_srli_epi16(off, 3), low5);
        const __m128i shift = _mm_and_si128(off, seven);
        const __m128i window = _mm_loadu_si128(reinterpret_cast<const __m128i*>(stream + pos / 8));
        const __m128i b0 = _mm_shuffle_epi8(window, byteAt);
        const __m128i b1 = _mm_shuffle_epi8(window, _mm_add_epi8(byteAt, one));
        // (two bytes << (8 - shift)) >> 8: the bits from the offset on in the low byte.
        const __m128i mLo = _mm_shuffle_epi8(mulLo, shift), mHi = _mm_shuffle_epi8(mulHi, shift);
        auto half = [](__m128i w, __m128i m) { return _mm_srli_epi16(_mm_mullo_epi16(w, m), 8); };
        const __m128i lo = half(_mm_unpacklo_epi8(b0, b1), _mm_unpacklo_epi8(mLo, mHi));
        const __m128i hi = half(_mm_unpackhi_epi8(b0, b1), _mm_unpackhi_epi8(mLo, mHi));
        const __m128i extra =
            _mm_and_si128(_mm_packus_epi16(lo, hi), _mm_shuffle_epi8(maskLut, count));
        _mm_storeu_si128(reinterpret_cast<__m128i*>(z + i), _mm_add_epi8(base, extra));
        pos += uint64_t(_mm_extract_epi8(sum, 15));
    }
    if (i > 0) bits.seek(pos);
    return i;
}
#endif

#if PLX_PTM_AVX512 && defined(__AVX512VBMI__)
// Per token (0..31, tokens 24..31 never decoded) its extra-bit count and its value without the
// extra bits (tokens below 16: the token itself), for vpermb.
struct ExtraBitTables32 {
    alignas(32) uint8_t bits[32]{}, base[32]{};
    constexpr ExtraBitTables32() {
        for (int t = 0; t < 32; ++t) {
            const int k = std::min(t, kTokenCount - 1);
            bits[t] = t < 16 ? 0 : kTokens.bits[size_t(k)];
            base[t] = t < 16 ? uint8_t(t) : uint8_t(kTokens.base[size_t(k)]);
        }
    }
};
inline constexpr ExtraBitTables32 kExtra32{};

// extraBitsAvx2 for thirty-two tokens per step (AVX-512 VBMI): counts and bases by vpermb, the
// byte-wise prefix sum of the counts across the 32 bytes by five masked vpermb shifts (32
// tokens hold at most 192 bits, so the offsets fit a byte and one 32-byte window of the stream
// holds the bits), each token's two bytes from the window by vpermb, the shift and the mask by
// 16-bit variable shifts. Reads the stream from bits' position while 32 bytes remain there,
// then moves it past the bits taken. Returns the number of tokens done. Bit-exact with the
// scalar take() loop.
inline int extraBitsAvx512(uint8_t* z, int n, BitReader& bits) {
    const __m256i bitsLut = _mm256_load_si256(reinterpret_cast<const __m256i*>(kExtra32.bits));
    const __m256i baseLut = _mm256_load_si256(reinterpret_cast<const __m256i*>(kExtra32.base));
    const __m256i index = _mm256_setr_epi8(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15,
                                           16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28,
                                           29, 30, 31);
    const __m512i one16 = _mm512_set1_epi16(1);
    const uint8_t* stream = bits.streamBegin();
    const size_t size = bits.streamBytes();
    uint64_t pos = bits.position();
    int i = 0;
    for (; i + 32 <= n && pos / 8 + 32 <= size; i += 32) {
        const __m256i t = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(z + i));
        const __m256i count = _mm256_permutexvar_epi8(t, bitsLut);
        const __m256i base = _mm256_permutexvar_epi8(t, baseLut);
        // Inclusive prefix sum: add the vector shifted up by 1, 2, 4, 8, 16 bytes.
        __m256i sum = count;
        for (int k = 1; k < 32; k *= 2) {
            const __m256i below = _mm256_sub_epi8(index, _mm256_set1_epi8(int8_t(k)));
            sum = _mm256_add_epi8(sum, _mm256_maskz_permutexvar_epi8(~0u << k, below, sum));
        }
        const __m256i off = _mm256_add_epi8(_mm256_sub_epi8(sum, count),
                                            _mm256_set1_epi8(int8_t(pos % 8)));
        const __m256i byteAt = _mm256_srli_epi16(_mm256_and_si256(off, _mm256_set1_epi8(-8)), 3);
        const __m256i window =
            _mm256_loadu_si256(reinterpret_cast<const __m256i*>(stream + pos / 8));
        const __m256i b0 = _mm256_permutexvar_epi8(byteAt, window);
        const __m256i b1 = _mm256_permutexvar_epi8(_mm256_add_epi8(byteAt, _mm256_set1_epi8(1)),
                                                   window);
        // (b1 b0 >> off mod 8) & (2^count - 1) in 16-bit lanes.
        const __m512i pair = _mm512_or_si512(_mm512_cvtepu8_epi16(b0),
                                             _mm512_slli_epi16(_mm512_cvtepu8_epi16(b1), 8));
        const __m512i shift = _mm512_cvtepu8_epi16(_mm256_and_si256(off, _mm256_set1_epi8(7)));
        const __m512i mask =
            _mm512_sub_epi16(_mm512_sllv_epi16(one16, _mm512_cvtepu8_epi16(count)), one16);
        const __m512i extra = _mm512_and_si512(_mm512_srlv_epi16(pair, shift), mask);
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(z + i),
                            _mm256_add_epi8(base, _mm512_cvtepi16_epi8(extra)));
        pos += uint64_t(uint8_t(_mm256_extract_epi8(sum, 31)));
    }
    if (i > 0) bits.seek(pos);
    return i;
}
#endif

// The tables of one family whose tokens are 0..3 (the eps runs, per component), held as
// vectors for runSmallAvx512: per table of the family (at most 16, lane = table - first), the
// cumulative starts of tokens 1..3 and the frequencies of tokens 0..3. An empty table decodes
// as buildSimdTable's: token 0 with frequency kRansTotal everywhere.
struct SmallAlphabet {
    alignas(64) uint32_t cum[3][16] = {};
    alignas(64) uint32_t freq[4][16] = {};
    int first = 0;
    bool usable = false;  // every table of the family holds tokens 0..3 only

    // From the frequencies of tables first..first+count-1; unusable (the family keeps the
    // table path) if count > 16 or a table has a token above 3.
    void build(std::span<const std::array<uint16_t, kTokenCount>> freqs, int firstTable,
               int count) {
        first = firstTable;
        usable = count <= 16;
        for (int l = 0; l < count && usable; ++l) {
            const auto& f = freqs[size_t(firstTable + l)];
            const bool empty = std::all_of(f.begin(), f.end(), [](uint16_t v) { return v == 0; });
            usable = std::all_of(f.begin() + 4, f.end(), [](uint16_t v) { return v == 0; });
            uint32_t start = 0;
            for (int t = 0; t < 4; ++t) {
                if (t > 0) cum[t - 1][l] = empty ? kRansTotal : start;
                freq[t][l] = empty ? (t == 0 ? kRansTotal : 0) : f[size_t(t)];
                start += f[size_t(t)];
            }
        }
    }
};

// Decoder IO for walkLevel: kSimdStates rANS states over a bounds-checked
// word stream, extra bits from a separate bit stream. Past the end of either stream reads give
// zeros and the overrun is recorded.
struct DecodeIO : WordStream {
    static constexpr bool kEncode = false;
    const uint32_t* entries;  // all tables, table t at t * kRansTotal
    // Per family (4c + kind), the context map's first table and `g`, as CtxMap: the walker's
    // contexts are table indices.
    std::array<CtxMap, 16> families{};
    BitReader bits;
    alignas(64) uint32_t x[kSimdStates] = {};
    int shapeEighths = 0;  // the group's mode byte (LevelRows)
    // The eps families (4c + 3) for runEps, when buildSmallAlphabets was called.
    std::array<SmallAlphabet, 4> eps{};

    // familyTables[f] = {first table, g} of family f (context map).
    // The stream stores the first `stored` states (simdStoredStates); the others start at 2^16.
    DecodeIO(const uint32_t* tableEntries,
                 const std::array<std::array<int, 2>, 16>& familyTables, int stored,
                 const uint8_t* begin, const uint8_t* streamEnd, BitReader extra)
        : WordStream{begin, streamEnd}, entries(tableEntries), bits(extra) {
        for (size_t f = 0; f < families.size(); ++f) {
            const int g = familyTables[f][1];
            const int mul = familyRawContexts(int(f) & 3) == 16 ? 512 * g : 683 * g;
            families[f] = {familyTables[f][0], mul};
        }
        for (int i = 0; i < kSimdStates; ++i) {
            x[i] = kRansLow;
            if (i < stored) {
                x[i] = readWord() << 16;
                x[i] |= readWord();
            }
        }
    }
    CtxMap ctxMap(int c, int kind) const { return families[size_t(4 * c + kind)]; }
    // Prepares runEps for the eps families of components 0..comps-1 (freqs: the group's
    // tables; familyTables as the constructor's).
    void buildSmallAlphabets(std::span<const std::array<uint16_t, kTokenCount>> freqs,
                             const std::array<std::array<int, 2>, 16>& familyTables, int comps) {
        for (int c = 0; c < comps; ++c) {
            const auto& [first, g] = familyTables[size_t(4 * c + 3)];
            eps[size_t(c)].build(freqs, first, g);
        }
    }
    // True when the stream was used up exactly and all states returned to their initial value.
    bool finishedCleanly() const { return WordStream::finishedCleanly(x); }

    // The symbols of a run, from the first, while whole rounds of kSimdStates symbols remain and
    // 2 kSimdStates bytes are left (a round reads at most one word per state); returns the first
    // symbol not done. The widest vector code the ISA has: runVectorAvx512 or runVectorAvx2.
    int runVector(const uint16_t* ctx, int n, uint8_t* tok) {
#if PLX_PTM_AVX512
        return runVectorAvx512(ctx, n, tok);
#else
        return runVectorAvx2(ctx, n, tok);
#endif
    }

#if PLX_PTM_AVX512
    // Whole rounds of kSimdStates symbols, sixteen states per AVX-512 vector, two vectors per
    // round, while 2 kSimdStates bytes of words are left: step(state, contexts, tokens) decodes
    // sixteen symbols (their contexts as 32-bit lanes), stores their tokens and returns the
    // states before renormalisation; refill512 renormalises them. Returns the symbols done.
    template <class Step>
    int roundsAvx512(const uint16_t* ctx, int n, uint8_t* tok, Step step) {
        constexpr int kLanes = 16, kVectors = kSimdStates / kLanes;
        __m512i s[kVectors];
        for (int v = 0; v < kVectors; ++v) s[v] = _mm512_load_si512(x + kLanes * v);
        const uint8_t* p = ptr;
        int j = 0;
        for (; j + kSimdStates <= n && end - p >= 2 * kSimdStates; j += kSimdStates) {
#pragma GCC unroll 2
            for (int v = 0; v < kVectors; ++v) {
                const int at = j + kLanes * v;
                const __m512i c = _mm512_cvtepu16_epi32(
                    _mm256_loadu_si256(reinterpret_cast<const __m256i*>(ctx + at)));
                s[v] = refill512(step(s[v], c, tok + at), p);
            }
        }
        ptr = p;
        for (int v = 0; v < kVectors; ++v) _mm512_store_si512(x + kLanes * v, s[v]);
        return j;
    }

    // The renormalisation of sixteen states: those below 2^16 take the next words at p in lane
    // order (vpexpandd), and p moves past them. Reads 32 bytes at p: the second vector of a
    // round reads at most 64 bytes past the round's start.
    static __m512i refill512(__m512i xs, const uint8_t*& p) {
        const __mmask16 below = _mm512_cmplt_epu32_mask(xs, _mm512_set1_epi32(int(kRansLow)));
        const __m512i words = _mm512_maskz_expand_epi32(
            below, _mm512_cvtepu16_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(p))));
        p += 2 * std::popcount(unsigned(below));
        return _mm512_mask_or_epi32(xs, below, _mm512_slli_epi32(xs, 16), words);
    }

    // runVector with AVX-512 (roundsAvx512): a vector's sixteen table entries by one vpgatherdd.
    int runVectorAvx512(const uint16_t* ctx, int n, uint8_t* tok) {
        const __m512i mask12 = _mm512_set1_epi32(int(kRansTotal - 1));
        const __m512i freqMask = _mm512_set1_epi32(int(kEntryFreqMask));
        const __m512i biasMask = _mm512_set1_epi32(0xFFF);
        const uint32_t* tables = entries;
        return roundsAvx512(ctx, n, tok, [&](__m512i s, __m512i table, uint8_t* out) {
            const __m512i slot = _mm512_and_si512(s, mask12);
            const __m512i e = _mm512_i32gather_epi32(
                _mm512_add_epi32(_mm512_slli_epi32(table, kRansPrecision), slot), tables, 4);
            _mm_storeu_si128(reinterpret_cast<__m128i*>(out),
                             _mm512_cvtepi32_epi8(_mm512_srli_epi32(e, kEntryTokenShift)));
            return _mm512_add_epi32(
                _mm512_mullo_epi32(_mm512_and_si512(e, freqMask),
                                   _mm512_srli_epi32(s, kRansPrecision)),
                _mm512_and_si512(_mm512_srli_epi32(e, kEntryBiasShift), biasMask));
        });
    }

    // runVectorAvx512 for a run whose contexts are tables of one SmallAlphabet family (tokens
    // 0..3): no table load on the chain from one state to the next. The lane's cumulative
    // starts and frequencies come from registers by its table (vpermd, known before the state),
    // the token is the number of starts <= slot (the starts do not decrease), then the state
    // update as the table path's. Bit-exact with the table path for such tables: a slot's
    // token is the last one whose start is <= slot, and its bias slot - start.
    int runSmallAvx512(const uint16_t* ctx, int n, uint8_t* tok, const SmallAlphabet& a) {
        auto row = [](const uint32_t* v) { return _mm512_load_si512(v); };
        const __m512i c1 = row(a.cum[0]), c2 = row(a.cum[1]), c3 = row(a.cum[2]);
        const __m512i f0 = row(a.freq[0]), f1 = row(a.freq[1]), f2 = row(a.freq[2]);
        const __m512i f3 = row(a.freq[3]);
        const __m512i first = _mm512_set1_epi32(a.first), one = _mm512_set1_epi32(1);
        const __m512i mask12 = _mm512_set1_epi32(int(kRansTotal - 1));
        return roundsAvx512(ctx, n, tok, [&](__m512i s, __m512i table, uint8_t* out) {
            const __m512i lane = _mm512_sub_epi32(table, first);
            const __m512i s1 = _mm512_permutexvar_epi32(lane, c1);
            const __m512i s2 = _mm512_permutexvar_epi32(lane, c2);
            const __m512i s3 = _mm512_permutexvar_epi32(lane, c3);
            const __m512i slot = _mm512_and_si512(s, mask12);
            const __mmask16 m1 = _mm512_cmple_epu32_mask(s1, slot);
            const __mmask16 m2 = _mm512_cmple_epu32_mask(s2, slot);
            const __mmask16 m3 = _mm512_cmple_epu32_mask(s3, slot);
            __m512i start = _mm512_maskz_mov_epi32(m1, s1);
            start = _mm512_mask_mov_epi32(start, m2, s2);
            start = _mm512_mask_mov_epi32(start, m3, s3);
            __m512i freq = _mm512_permutexvar_epi32(lane, f0);
            freq = _mm512_mask_permutexvar_epi32(freq, m1, lane, f1);
            freq = _mm512_mask_permutexvar_epi32(freq, m2, lane, f2);
            freq = _mm512_mask_permutexvar_epi32(freq, m3, lane, f3);
            const __m512i t = _mm512_add_epi32(
                _mm512_maskz_mov_epi32(m1, one),
                _mm512_add_epi32(_mm512_maskz_mov_epi32(m2, one),
                                 _mm512_maskz_mov_epi32(m3, one)));
            _mm_storeu_si128(reinterpret_cast<__m128i*>(out), _mm512_cvtepi32_epi8(t));
            return _mm512_add_epi32(_mm512_mullo_epi32(freq, _mm512_srli_epi32(s, kRansPrecision)),
                                    _mm512_sub_epi32(slot, start));
        });
    }
#endif

    // runVector with eight states per AVX2 vector, four vectors per round (the last vector's
    // 16-byte word load starts at most 48 bytes in).
    int runVectorAvx2(const uint16_t* ctx, int n, uint8_t* tok) {
        int j = 0;
#if defined(__AVX2__)
        const __m256i mask12 = _mm256_set1_epi32(int(kRansTotal - 1));
        const __m256i freqMask = _mm256_set1_epi32(int(kEntryFreqMask));
        const __m256i biasMask = _mm256_set1_epi32(0xFFF);
        const __m256i zero = _mm256_setzero_si256();
        const __m256i permShift = _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21);
        const __m256i seven = _mm256_set1_epi32(7);
        // Byte 0 of each 32-bit lane to the low 4 bytes of each 128-bit half.
        const __m256i tokBytes = _mm256_setr_epi8(0, 4, 8, 12, -1, -1, -1, -1, -1, -1, -1, -1,
                                                  -1, -1, -1, -1, 0, 4, 8, 12, -1, -1, -1, -1,
                                                  -1, -1, -1, -1, -1, -1, -1, -1);
        const int* const tab = reinterpret_cast<const int*>(entries);
        __m256i s[kSimdVectors];
        for (int v = 0; v < kSimdVectors; ++v)
            s[v] = _mm256_load_si256(reinterpret_cast<const __m256i*>(x + 8 * v));
        const uint8_t* p = ptr;
        for (; j + kSimdStates <= n && end - p >= 2 * kSimdStates; j += kSimdStates) {
#pragma GCC unroll 4
            for (int v = 0; v < kSimdVectors; ++v) {
                const __m256i off = _mm256_slli_epi32(
                    _mm256_cvtepu16_epi32(
                        _mm_loadu_si128(reinterpret_cast<const __m128i*>(ctx + j + 8 * v))),
                    kRansPrecision);
                const __m256i slot = _mm256_and_si256(s[v], mask12);
                // Eight scalar loads: faster than an 8-lane vpgatherdd on Zen 3, and checked
                // by AddressSanitizer.
                alignas(32) uint32_t ix[8];
                _mm256_store_si256(reinterpret_cast<__m256i*>(ix), _mm256_add_epi32(off, slot));
                const __m256i e = _mm256_setr_epi32(tab[ix[0]], tab[ix[1]], tab[ix[2]],
                                                    tab[ix[3]], tab[ix[4]], tab[ix[5]],
                                                    tab[ix[6]], tab[ix[7]]);
                const __m256i freq = _mm256_and_si256(e, freqMask);
                const __m256i bias =
                    _mm256_and_si256(_mm256_srli_epi32(e, kEntryBiasShift), biasMask);
                __m256i xs = _mm256_add_epi32(
                    _mm256_mullo_epi32(freq, _mm256_srli_epi32(s[v], kRansPrecision)), bias);
                const __m256i t = _mm256_shuffle_epi8(_mm256_srli_epi32(e, kEntryTokenShift),
                                                      tokBytes);
                const uint32_t lo = uint32_t(_mm256_cvtsi256_si32(t));
                const uint32_t hi = uint32_t(_mm_cvtsi128_si32(_mm256_extracti128_si256(t, 1)));
                std::memcpy(tok + j + 8 * v, &lo, 4);
                std::memcpy(tok + j + 8 * v + 4, &hi, 4);
                // Renormalisation: lanes below 2^16 take the next words in lane order.
                const __m256i low = _mm256_cmpeq_epi32(_mm256_srli_epi32(xs, 16), zero);
                const unsigned m = unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(low)));
                const __m256i words = _mm256_cvtepu16_epi32(
                    _mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
                const __m256i perm = _mm256_and_si256(
                    _mm256_srlv_epi32(_mm256_set1_epi32(int(kRenormPerm.packed[m])), permShift),
                    seven);
                const __m256i refilled = _mm256_or_si256(
                    _mm256_slli_epi32(xs, 16), _mm256_permutevar8x32_epi32(words, perm));
                s[v] = _mm256_blendv_epi8(xs, refilled, low);
                p += 2 * std::popcount(m);
            }
        }
        ptr = p;
        for (int v = 0; v < kSimdVectors; ++v)
            _mm256_store_si256(reinterpret_cast<__m256i*>(x + 8 * v), s[v]);
#else
        (void)ctx;
        (void)n;
        (void)tok;
#endif
        return j;
    }

    // Symbols j..n-1 of a run by the scalar decoder: the tail of a run and the stream's end,
    // with checked word reads.
    void runScalar(const uint16_t* ctx, int j, int n, uint8_t* tok) {
        for (; j < n; ++j) {
            uint32_t& st = x[j % kSimdStates];
            const uint32_t slot = st & (kRansTotal - 1);
            const uint32_t e = entries[(uint32_t(ctx[j]) << kRansPrecision) + slot];
            st = (e & kEntryFreqMask) * (st >> kRansPrecision) + ((e >> kEntryBiasShift) & 0xFFF);
            if (st < kRansLow) st = (st << 16) | readWord();
            tok[j] = uint8_t(e >> kEntryTokenShift);
        }
    }

    // The eps run of component c (n symbols, contexts ctx, tokens into z): with AVX-512 by
    // runSmallAvx512 where the family allows it, else as run<false>.
    void runEps([[maybe_unused]] int c, const uint16_t* ctx, int n, uint8_t* z) {
#if PLX_PTM_AVX512
        if (eps[size_t(c)].usable) {
            runScalar(ctx, runSmallAvx512(ctx, n, z, eps[size_t(c)]), n, z);
            return;
        }
#endif
        run<false>(ctx, n, z);
    }

    // A run of n symbols with contexts ctx: tokens (kExtra: plus their extra bits) into z.
    // kFast = false decodes every symbol with the scalar loops (the reference of
    // fast_paths_test).
    template <bool kExtra, bool kFast = true>
    void run(const uint16_t* ctx, int n, uint8_t* z) {
        runScalar(ctx, kFast ? runVector(ctx, n, z) : 0, n, z);
        if constexpr (kExtra) {
            int i = 0;
#if PLX_PTM_AVX512 && defined(__AVX512VBMI__)
            if constexpr (kFast) i = extraBitsAvx512(z, n, bits);
#endif
#if defined(__AVX2__)
            if constexpr (kFast) i += extraBitsAvx2(z + i, n - i, bits);
#endif
            BitReader br = bits;  // a local: the byte stores to z cannot alias it
            for (; i + 8 <= n; i += 8) {
                uint64_t eight;
                std::memcpy(&eight, z + i, 8);
                if ((eight & 0xF0F0F0F0F0F0F0F0ull) == 0) continue;  // tokens < 16: no extra bits
                // A token has at most 6 extra bits: ensure24 covers four tokens.
                for (int h = 0; h < 8; h += 4) {
                    br.ensure24();
#pragma GCC unroll 4
                    for (int l = h; l < h + 4; ++l) {
                        const size_t t = z[i + l];
                        z[i + l] = uint8_t(kTokens.base[t] + br.take(kTokens.bits[t]));
                    }
                }
            }
            for (; i < n; ++i) {
                br.ensure24();
                const size_t t = z[i];
                z[i] = uint8_t(kTokens.base[t] + br.take(kTokens.bits[t]));
            }
            bits = br;
        }
    }
};

}  // namespace PLX_PTM_KERNEL_NS
}  // namespace plx::ptm::detail
