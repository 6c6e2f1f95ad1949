#pragma once
// Progressive PTM decoding: parse the header, then feed level groups smallest first; each group
// yields its level as soon as its bytes arrive. Builds without the encoder (plx_ptm_decode).
// Every input byte is untrusted: failures come back as Status naming the problem.
// Memory: each thread that decodes modelled groups keeps one buffer for their decode tables
// (16 KB per table, up to 4 MB; 2.5 MB for an RGB texture), reused by every later group on that
// thread instead of being allocated and faulted in again per group.
// The decode loops take the widest SIMD path the CPU has (<plx/core/cpu.h>, activeIsa()).

#include <span>
#include <vector>

#include <plx/core/image.h>
#include <plx/core/status.h>
#include <plx/ptm/format.h>

namespace plx::ptm {

class ProgressiveDecoder {
public:
    // Parses header and level index from the first bytes of a file (at least
    // headerBytesFor(levelCount); kFixedHeaderBytes tell the level count).
    static Result<ProgressiveDecoder> create(std::span<const uint8_t> headerPrefix);

    const Header& header() const { return mHeader; }
    // Levels decoded so far; the next group to feed is levelsDecoded().
    int levelsDecoded() const { return int(mLevels.size()); }
    bool complete() const { return levelsDecoded() == mHeader.levelCount; }

    // Decodes the next level group (the bytes of levelByteRange(header(), levelsDecoded())).
    // Checks size and CRC-32 before decoding. Precondition: !complete().
    Status addGroup(std::span<const uint8_t> groupBytes);

    // Stored level k (0 = smallest). Precondition: k < levelsDecoded().
    const ByteImage& level(int k) const;
    // Hands over the decoded levels (index 0 smallest) and leaves the decoder empty.
    std::vector<ByteImage> takeLevels() { return std::move(mLevels); }

private:
    explicit ProgressiveDecoder(Header header) : mHeader(std::move(header)) {}
    Header mHeader;
    std::vector<ByteImage> mLevels;
};

// Decodes stored level k (0 = smallest) from a prefix of a file holding at least groups 0..k.
Result<ByteImage> decodeLevel(std::span<const uint8_t> filePrefix, int k);

// Decodes the full-resolution level from a whole file.
Result<ByteImage> decodeImage(std::span<const uint8_t> file);

// Decodes every stored level, index 0 the smallest.
Result<std::vector<ByteImage>> decodeAllLevels(std::span<const uint8_t> file);

}  // namespace plx::ptm
