#pragma once
// Private: the bit and word streams of a modelled group (docs/ptm-format.md, "Level groups"):
// the rANS renormalisation words and the separate LSB-first stream of extra bits. Every read is
// bounds-checked: past the end it yields zeros and records the overrun instead of touching
// memory outside the group.

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "kernel_ns.h"
#include "rans.h"

namespace plx::ptm::detail {
inline namespace PLX_PTM_KERNEL_NS {

// LSB-first writer of the extra bits into a caller-owned buffer of at least
// (bits to write + 7) / 8 bytes (the encoder sizes it from the symbol count, 6 bits each at most).
class BitSink {
public:
    explicit BitSink(uint8_t* out) : mOut(out) {}
    void put(uint32_t bits, int n) {
        mAcc |= uint64_t(bits) << mCount;
        mCount += n;
        while (mCount >= 8) {
            mOut[mBytes++] = uint8_t(mAcc);
            mAcc >>= 8;
            mCount -= 8;
        }
    }
    size_t bitCount() const { return mBytes * 8 + size_t(mCount); }
    // Writes the last partial byte; returns the stream's length in bytes.
    size_t finish() {
        if (mCount > 0) mOut[mBytes++] = uint8_t(mAcc);
        mAcc = 0;
        mCount = 0;
        return mBytes;
    }

private:
    uint8_t* mOut;
    size_t mBytes = 0;
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


}  // namespace PLX_PTM_KERNEL_NS
}  // namespace plx::ptm::detail
