// libFuzzer target: the PTM decoder on arbitrary bytes (whole-file, per-level and progressive
// paths). It must return errors, never crash, hang or read out of bounds.

#include <cstddef>
#include <cstdint>
#include <span>

#include <plx/ptm/decoder.h>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    std::span<const uint8_t> bytes(data, size);
    auto header = plx::ptm::parseHeader(bytes);
    if (!header) return 0;
    // Keep memory within libFuzzer's default RSS limit: large but valid images are not bugs.
    if (int64_t(header->width) * header->height > (int64_t(1) << 22)) return 0;
    (void)plx::ptm::decodeImage(bytes);
    (void)plx::ptm::decodeLevel(bytes, header->levelCount / 2);
    auto dec = plx::ptm::ProgressiveDecoder::create(bytes);
    if (!dec) return 0;
    for (int k = 0; k < header->levelCount; ++k) {
        const plx::ptm::ByteRange r = plx::ptm::levelByteRange(*header, k);
        if (r.offset + r.size > size) break;
        if (!dec->addGroup(bytes.subspan(size_t(r.offset), size_t(r.size))).isOk()) break;
    }
    return 0;
}
