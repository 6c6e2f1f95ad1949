// libFuzzer target: the PTM decoder on arbitrary bytes (whole-file, per-level and progressive
// paths). It must return errors, never crash, hang or read out of bounds.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <plx/ptm/decoder.h>

namespace {

void putU32(std::vector<uint8_t>& f, size_t at, uint32_t v) {
    for (int i = 0; i < 4; ++i) f[at + size_t(i)] = uint8_t(v >> (8 * i));
}

// The input with the header CRC and every whole group's index CRC recomputed, so that mutations
// reach the entropy decoders instead of stopping at a checksum. Empty if the header is unusable.
std::vector<uint8_t> withFixedChecksums(std::span<const uint8_t> in) {
    if (in.size() < plx::ptm::kFixedHeaderBytes) return {};
    std::vector<uint8_t> f(in.begin(), in.end());
    const size_t headerBytes = plx::ptm::headerBytesFor(f[20]);
    if (f[20] == 0 || headerBytes > f.size()) return {};
    auto fixHeader = [&] {
        putU32(f, headerBytes - 4, plx::ptm::crc32(std::span(f).first(headerBytes - 4)));
    };
    fixHeader();
    auto header = plx::ptm::parseHeader(f);
    if (!header) return {};
    for (int k = 0; k < header->levelCount; ++k) {
        const plx::ptm::ByteRange r = plx::ptm::levelByteRange(*header, k);
        if (r.offset + r.size > f.size()) break;
        putU32(f, plx::ptm::kFixedHeaderBytes + size_t(k) * plx::ptm::kIndexEntryBytes + 16,
               plx::ptm::crc32(std::span(f).subspan(size_t(r.offset), size_t(r.size))));
    }
    fixHeader();
    return f;
}

void decodeAllWays(std::span<const uint8_t> bytes) {
    auto header = plx::ptm::parseHeader(bytes);
    if (!header) return;
    // Keep memory within libFuzzer's default RSS limit: large but valid images are not bugs.
    if (int64_t(header->width) * header->height > (int64_t(1) << 22)) return;
    (void)plx::ptm::decodeImage(bytes);
    (void)plx::ptm::decodeLevel(bytes, header->levelCount / 2);
    auto dec = plx::ptm::ProgressiveDecoder::create(bytes);
    if (!dec) return;
    for (int k = 0; k < header->levelCount; ++k) {
        const plx::ptm::ByteRange r = plx::ptm::levelByteRange(*header, k);
        if (r.offset + r.size > bytes.size()) break;
        if (!dec->addGroup(bytes.subspan(size_t(r.offset), size_t(r.size))).isOk()) break;
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    std::span<const uint8_t> bytes(data, size);
    decodeAllWays(bytes);
    const std::vector<uint8_t> fixed = withFixedChecksums(bytes);
    if (!fixed.empty()) decodeAllWays(fixed);
    return 0;
}
