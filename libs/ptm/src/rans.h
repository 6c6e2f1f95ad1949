#pragma once
// Private: the entropy coder of the modelled coder (docs/ptm-format.md, "Entropy coding"): the
// token alphabet, the frequency tables and their serialisation, the decode tables and the rANS
// encoders. Declares what rans.cpp defines, plus the constants and one-line helpers those use.
//
// - Symbols are *tokens* of a hybrid-uint code (as JPEG XL's, split exponent 4, one mantissa bit
//   in the token): a value z in 0..255 is token z when z < 16, else with n = floor(log2 z) token
//   16 + 2 (n - 4) + (bit n-1 of z), followed by the n - 1 low bits of z as raw extra bits.
//   24 tokens cover 0..255.
// - Tokens are coded with static per-context frequency tables (12-bit precision) by interleaved
//   rANS states (32-bit state, 16-bit renormalisation words): two in group 0, kSimdStates in the
//   other groups. Extra bits go to a separate LSB-first bit stream.

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace plx::ptm::detail {

inline constexpr int kRansPrecision = 12;
inline constexpr uint32_t kRansTotal = 1u << kRansPrecision;  // frequencies sum to this
inline constexpr uint32_t kRansLow = 1u << 16;                // state interval [2^16, 2^32)
inline constexpr int kTokenCount = 24;

// Hybrid-uint split of z (0..255) into token, extra-bit count and extra bits.
struct TokenSplit {
    int token = 0;
    int bits = 0;
    uint32_t extra = 0;
};
inline TokenSplit splitToken(uint32_t z) {
    if (z < 16) return {int(z), 0, 0};
    const int n = std::bit_width(z) - 1;  // 4..7
    return {16 + 2 * (n - 4) + int((z >> (n - 1)) & 1), n - 1, z & ((1u << (n - 1)) - 1)};
}
// Inverse: z = tokenBase[token] + (extra bits, tokenBits[token] of them).
struct TokenTables {
    std::array<uint16_t, kTokenCount> base{};
    std::array<uint8_t, kTokenCount> bits{};
    constexpr TokenTables() {
        for (int t = 0; t < kTokenCount; ++t) {
            if (t < 16) {
                base[size_t(t)] = uint16_t(t);
                bits[size_t(t)] = 0;
            } else {
                const int n = 4 + (t - 16) / 2;
                base[size_t(t)] = uint16_t((1 << n) | ((t & 1) << (n - 1)));
                bits[size_t(t)] = uint8_t(n - 1);
            }
        }
    }
};
inline constexpr TokenTables kTokens{};

// Signed residual (value - prediction as int8) to 0..255 and back.
inline uint32_t zigzag(int r) { return r >= 0 ? uint32_t(2 * r) : uint32_t(-2 * r - 1); }
inline int unzigzag(uint32_t z) { return (z & 1) ? -int((z + 1) >> 1) : int(z >> 1); }

// Normalises counts to frequencies summing to kRansTotal; every counted token keeps >= 1.
// An all-zero histogram gives all-zero frequencies (an empty table).
std::array<uint16_t, kTokenCount> normalizeCounts(const std::array<uint32_t, kTokenCount>& c);

// Compact table serialisation: byte L = 1 + last token with a non-zero frequency (0 = empty),
// then the frequencies of tokens 0..L-2 as LEB128 varints; the last one is implied (the rest of
// kRansTotal, >= 1).
void writeTable(std::vector<uint8_t>& out, const std::array<uint16_t, kTokenCount>& freq);
// Reads one table; false if it is malformed (sum over kRansTotal, truncated, L too large).
bool readTable(const uint8_t*& p, const uint8_t* end, std::array<uint16_t, kTokenCount>& freq);
// Bytes writeTable would use.
size_t tableBytes(const std::array<uint16_t, kTokenCount>& freq);

// Decode table of one context for group 0: per token its start and frequency, 32 entries (the
// tail padded with starts beyond kRansTotal). 128 bytes, so the tables of a whole group stay in
// L1. The token of a slot is found branch-free by counting the starts <= slot.
struct DecodeTable {
    alignas(64) uint16_t cum[32];
    uint16_t freq[32];
    int find(uint32_t slot) const {
        int count = 0;
        for (int t = 0; t < 32; ++t) count += cum[t] <= slot ? 1 : 0;
        return count - 1;  // the last token starting at or before slot: its frequency is > 0
    }
};
// Fills t from freq (sum kRansTotal, or all zero: then every slot decodes token 0 with
// frequency kRansTotal, which keeps the state and is caught by the final state check).
void buildDecodeTable(const std::array<uint16_t, kTokenCount>& freq, DecodeTable& t);

// One coded symbol of group 0 as the encoder collects them, in decode order.
struct CodedSymbol {
    uint16_t ctx;
    uint8_t token;
};

// rANS-encodes group 0's symbols (decode order) with per-context frequencies over two states;
// returns the stream: the two final states (state 0 first, high then low 16-bit word) then the
// renormalisation words, each 16-bit word little-endian. Precondition: every symbol's
// frequency is > 0.
std::vector<uint8_t> ransEncode(std::span<const CodedSymbol> symbols,
                                const std::vector<std::array<uint16_t, kTokenCount>>& freqs,
                                const std::vector<uint16_t>& ctxToTable);

inline constexpr int kSimdStates = 32;
inline constexpr int kSimdVectors = kSimdStates / 8;

// States a group stores (the others are unused and stay 2^16): as many as the longest run of the
// level (C times the blocks of a block row that code p00, at least C), at most kSimdStates.
inline int simdStoredStates(int comps, int width) {
    return std::min(kSimdStates, comps * std::max(1, width / 2));
}

// Decode entry of one slot: frequency in bits 0..12 (1..4096), slot - cumulative start in bits
// 13..24, token in bits 27..31.
inline constexpr uint32_t kEntryFreqMask = 0x1FFF;
inline constexpr int kEntryBiasShift = 13;
inline constexpr int kEntryTokenShift = 27;


// One symbol of a group k >= 1 as the encoder collects them: context, token and rANS state.
struct LaneSymbol {
    uint16_t ctx;
    uint8_t token;
    uint8_t lane;
};
// rANS-encodes symbols (decode order) with per-context frequencies over kSimdStates states;
// symbol i uses state lane[i]. Returns the final states of lanes 0..stored-1 (state 0 first,
// each as high then low 16-bit word; lanes from `stored` on must be unused) then the
// renormalisation words, each 16-bit word little-endian.
std::vector<uint8_t> ransEncodeLanes(std::span<const LaneSymbol> symbols,
                                     const std::vector<std::array<uint16_t, kTokenCount>>& freqs,
                                     const std::vector<uint16_t>& ctxToTable, int stored);

}  // namespace plx::ptm::detail
