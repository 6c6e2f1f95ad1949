#pragma once
// Private: the entropy coder of Coder::kPredictRans (docs/ptm-format.md, "Coder 2").
//
// - Symbols are *tokens* of a hybrid-uint code (as JPEG XL's, split exponent 4, one mantissa bit
//   in the token): a value z in 0..255 is token z when z < 16, else with n = floor(log2 z) token
//   16 + 2 (n - 4) + (bit n-1 of z), followed by the n - 1 low bits of z as raw extra bits.
//   24 tokens cover 0..255.
// - Tokens are coded with static per-context frequency tables (12-bit precision) by two
//   interleaved rANS states (32-bit state, 16-bit renormalisation words): symbol i uses state
//   i mod 2. Extra bits go to a separate LSB-first bit stream.
// - Everything the decoder reads is bounds-checked; running off the end sets a flag (reads give
//   zeros) instead of touching memory outside the group.

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
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

// LSB-first bit writer for the extra bits.
class BitWriter {
public:
    void put(uint32_t bits, int n) {
        mAcc |= uint64_t(bits) << mCount;
        mCount += n;
        while (mCount >= 8) {
            mBytes.push_back(uint8_t(mAcc));
            mAcc >>= 8;
            mCount -= 8;
        }
    }
    size_t bitCount() const { return mBytes.size() * 8 + size_t(mCount); }
    std::vector<uint8_t> finish() {
        if (mCount > 0) mBytes.push_back(uint8_t(mAcc));
        mAcc = 0;
        mCount = 0;
        return std::move(mBytes);
    }

private:
    std::vector<uint8_t> mBytes;
    uint64_t mAcc = 0;
    int mCount = 0;
};

// Bounds-checked LSB-first bit reader; past the end it yields zeros and counts the overrun.
class BitReader {
public:
    BitReader(const uint8_t* begin, const uint8_t* end) : mBegin(begin), mPtr(begin), mEnd(end) {
        refill();
    }
    uint32_t get(int n) {  // n in 0..24
        if (mCount < 24) refill();
        return take(n);
    }
    // Makes at least 24 bits available to take().
    void ensure24() {
        if (mCount < 24) refill();
    }
    // n bits (0..24) of those made available by ensure24().
    uint32_t take(int n) {
        const uint32_t v = uint32_t(mAcc) & ((1u << n) - 1);
        mAcc >>= n;
        mCount -= n;
        return v;
    }
    // Bits taken so far, counted from the stream's first byte.
    uint64_t position() const {
        return (uint64_t(mPtr - mBegin) + mVirtual) * 8 - uint64_t(mCount);
    }
    // The stream, for readers that decode from position() on by themselves and then seek().
    const uint8_t* streamBegin() const { return mBegin; }
    size_t streamBytes() const { return size_t(mEnd - mBegin); }
    // Continues at bit pos (at most the stream's length in bits), as if pos bits had been taken.
    void seek(uint64_t pos) {
        mPtr = mBegin + pos / 8;
        mAcc = 0;
        mCount = 0;
        mVirtual = 0;
        refill();
        take(int(pos % 8));
    }
    // True when exactly the stream's bytes were used (the last one possibly in part).
    bool exact(size_t streamBytes) const { return (position() + 7) / 8 == streamBytes; }

private:
    void refill() {
        if (mEnd - mPtr >= 8) {
            uint64_t v;
            std::memcpy(&v, mPtr, 8);  // little-endian hosts only (checked in decoder.cpp)
            mAcc |= v << mCount;
            const int take = (63 - mCount) >> 3;
            mPtr += take;
            mCount += take * 8;
            return;
        }
        while (mCount <= 56) {
            if (mPtr < mEnd)
                mAcc |= uint64_t(*mPtr++) << mCount;
            else
                ++mVirtual;  // a zero byte past the end
            mCount += 8;
        }
    }
    const uint8_t* mBegin;
    const uint8_t* mPtr;
    const uint8_t* mEnd;
    uint64_t mAcc = 0;
    int mCount = 0;
    uint64_t mVirtual = 0;
};

// Decode table of one context: per token its start and frequency, 32 entries (the tail padded
// with starts beyond kRansTotal). 128 bytes, so the tables of a whole group stay in L1. The token
// of a slot is found branch-free by counting the starts <= slot (a loop the compiler vectorises),
// instead of a 4096-entry slot table per context.
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

// One coded symbol as the encoder collects them, in decode order.
struct CodedSymbol {
    uint16_t ctx;
    uint8_t token;
};

// rANS-encodes symbols (decode order) with per-context frequencies; returns the stream: the two
// final states (state 0 first, big-endian 16-bit halves as words) then the renormalisation
// words, each 16-bit word little-endian. Precondition: every symbol's frequency is > 0.
std::vector<uint8_t> ransEncode(const std::vector<CodedSymbol>& symbols,
                                const std::vector<std::array<uint16_t, kTokenCount>>& freqs,
                                const std::vector<uint16_t>& ctxToTable);

// The renormalisation words of a rANS stream (16-bit, little-endian), bounds-checked: past the
// end a read gives zero and records the overrun. Shared by every rANS decoder.
struct WordStream {
    const uint8_t* ptr;
    const uint8_t* end;
    bool overrun = false;

    uint32_t readWord() {
        if (end - ptr >= 2) {
            const uint32_t w = uint32_t(ptr[0]) | uint32_t(ptr[1]) << 8;
            ptr += 2;
            return w;
        }
        overrun = true;
        return 0;
    }
    // True when the stream was used up exactly and every state is back at its initial value.
    template <size_t N>
    bool finishedCleanly(const uint32_t (&states)[N]) const {
        bool initial = true;
        for (uint32_t s : states) initial = initial && s == kRansLow;
        return !overrun && ptr == end && initial;
    }
};

// Two-state interleaved rANS decoder over a bounds-checked word stream.
class RansDecoder {
public:
    RansDecoder(const uint8_t* begin, const uint8_t* end) : mWords{begin, end} {
        mX0 = readWord() << 16;
        mX0 |= readWord();
        mX1 = readWord() << 16;
        mX1 |= readWord();
    }
    int decode(const DecodeTable& t) {
        const uint32_t slot = mX0 & (kRansTotal - 1);
        const int tok = t.find(slot);
        uint32_t x = uint32_t(t.freq[tok]) * (mX0 >> kRansPrecision) + slot - t.cum[tok];
        if (x < kRansLow) x = (x << 16) | readWord();
        mX0 = mX1;
        mX1 = x;
        return tok;
    }
    // True when the stream was used up exactly and both states returned to their initial value.
    bool finishedCleanly() const {
        const uint32_t states[2] = {mX0, mX1};
        return mWords.finishedCleanly(states);
    }

private:
    uint32_t readWord() { return mWords.readWord(); }
    WordStream mWords;
    uint32_t mX0 = 0, mX1 = 0;
};

}  // namespace plx::ptm::detail
