// One-shot zstd frames with their content size recorded, decoded only into a buffer of exactly
// the size the view header promised (so a small frame cannot expand past what was allocated).

#include <memory>

#include <zstd.h>

#include <fmt/format.h>

#include "payloads.h"

namespace plx::remote {
namespace {

// One context of each kind per thread, reused: ZSTD_compress and ZSTD_decompress would allocate,
// clear and free theirs (about a megabyte at level 3) for every view.
struct ContextFree {
    void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
    void operator()(ZSTD_DCtx* d) const { ZSTD_freeDCtx(d); }
};

ZSTD_CCtx* threadCompressor() {
    thread_local const std::unique_ptr<ZSTD_CCtx, ContextFree> context(ZSTD_createCCtx());
    return context.get();
}

ZSTD_DCtx* threadDecompressor() {
    thread_local const std::unique_ptr<ZSTD_DCtx, ContextFree> context(ZSTD_createDCtx());
    return context.get();
}

}  // namespace

Status zstdCompress(std::span<const uint8_t> in, int level, std::vector<uint8_t>* out) {
    ZSTD_CCtx* context = threadCompressor();
    if (!context) return {ErrorCode::kInternal, "zstd: cannot create a compression context"};
    // Into an uninitialised bound-sized buffer, then only the frame is copied: a vector resized
    // to the bound would first clear it (the whole input's size, for a frame a tenth of it).
    const size_t bound = ZSTD_compressBound(in.size());
    const std::unique_ptr<uint8_t[]> frame(new uint8_t[bound]);
    const size_t n = ZSTD_compressCCtx(context, frame.get(), bound, in.data(), in.size(), level);
    if (ZSTD_isError(n)) {
        return {ErrorCode::kInternal, fmt::format("zstd: {}", ZSTD_getErrorName(n))};
    }
    out->assign(frame.get(), frame.get() + n);
    return {};
}

Result<uint64_t> zstdFrameContentSize(std::span<const uint8_t> in, const char* field) {
    const unsigned long long declared = ZSTD_getFrameContentSize(in.data(), in.size());
    if (declared == ZSTD_CONTENTSIZE_ERROR || declared == ZSTD_CONTENTSIZE_UNKNOWN) {
        return Status(ErrorCode::kCorruptData,
                      fmt::format("{}: not a zstd frame with its size", field));
    }
    // Exactly one frame: trailing bytes after it are refused like any others.
    const size_t frameBytes = ZSTD_findFrameCompressedSize(in.data(), in.size());
    if (ZSTD_isError(frameBytes)) {
        return Status(ErrorCode::kCorruptData, fmt::format("{}: truncated zstd frame", field));
    }
    if (frameBytes != in.size()) {
        return Status(ErrorCode::kCorruptData, fmt::format("{}: {} bytes after the zstd frame",
                                                           field, in.size() - frameBytes));
    }
    return uint64_t(declared);
}

Status checkZstdFrame(std::span<const uint8_t> in, size_t expected, const char* field) {
    const Result<uint64_t> declared = zstdFrameContentSize(in, field);
    if (!declared) return declared.status();
    if (*declared != expected) {
        return {ErrorCode::kCorruptData,
                fmt::format("{}: zstd frame of {} bytes, expected {}", field, *declared, expected)};
    }
    return {};
}

Status zstdDecompressExact(std::span<const uint8_t> in, std::span<uint8_t> out, const char* field) {
    PLX_RETURN_IF_ERROR(checkZstdFrame(in, out.size(), field));
    ZSTD_DCtx* context = threadDecompressor();
    if (!context) return {ErrorCode::kInternal, "zstd: cannot create a decompression context"};
    const size_t n = ZSTD_decompressDCtx(context, out.data(), out.size(), in.data(), in.size());
    if (ZSTD_isError(n) || n != out.size()) {
        return {ErrorCode::kCorruptData,
                fmt::format("{}: zstd: {}", field,
                            ZSTD_isError(n) ? ZSTD_getErrorName(n) : "short frame")};
    }
    return {};
}

}  // namespace plx::remote
