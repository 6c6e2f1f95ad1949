// One-shot zstd frames with their content size recorded, decoded only into a buffer of exactly
// the size the view header promised (so a small frame cannot expand past what was allocated).

#include <zstd.h>

#include <fmt/format.h>

#include "payloads.h"

namespace plx::remote {

Status zstdCompress(std::span<const uint8_t> in, int level, std::vector<uint8_t>* out) {
    out->resize(ZSTD_compressBound(in.size()));
    const size_t n = ZSTD_compress(out->data(), out->size(), in.data(), in.size(), level);
    if (ZSTD_isError(n)) {
        return {ErrorCode::kInternal, fmt::format("zstd: {}", ZSTD_getErrorName(n))};
    }
    out->resize(n);
    return {};
}

Status checkZstdFrame(std::span<const uint8_t> in, size_t expected, const char* field) {
    const unsigned long long declared = ZSTD_getFrameContentSize(in.data(), in.size());
    if (declared == ZSTD_CONTENTSIZE_ERROR || declared == ZSTD_CONTENTSIZE_UNKNOWN) {
        return {ErrorCode::kCorruptData, fmt::format("{}: not a zstd frame with its size", field)};
    }
    if (declared != expected) {
        return {ErrorCode::kCorruptData,
                fmt::format("{}: zstd frame of {} bytes, expected {}", field, declared, expected)};
    }
    // Exactly one frame: trailing bytes after it are refused like any others.
    const size_t frameBytes = ZSTD_findFrameCompressedSize(in.data(), in.size());
    if (ZSTD_isError(frameBytes)) {
        return {ErrorCode::kCorruptData, fmt::format("{}: truncated zstd frame", field)};
    }
    if (frameBytes != in.size()) {
        return {ErrorCode::kCorruptData,
                fmt::format("{}: {} bytes after the zstd frame", field, in.size() - frameBytes)};
    }
    return {};
}

Status zstdDecompressExact(std::span<const uint8_t> in, std::span<uint8_t> out, const char* field) {
    PLX_RETURN_IF_ERROR(checkZstdFrame(in, out.size(), field));
    const size_t n = ZSTD_decompress(out.data(), out.size(), in.data(), in.size());
    if (ZSTD_isError(n) || n != out.size()) {
        return {ErrorCode::kCorruptData,
                fmt::format("{}: zstd: {}", field,
                            ZSTD_isError(n) ? ZSTD_getErrorName(n) : "short frame")};
    }
    return {};
}

}  // namespace plx::remote
