// Disparity payloads. q16: the disparity delta = 1/w is affine in the pixel position across a
// plane seen in perspective, so along a row its second difference vanishes on every planar
// surface (the "highly compressible" disparity of Mark, Bishop, McMillan, citing Guenter et al.);
// quantised to 16 bits over the view's own range, predicted by 2a - b and zigzag-coded, the
// residuals are mostly 0 and +-1 and zstd (zlib for browsers) packs them. q16-packed gives zstd
// the same residuals as two-bit symbols min(z, 3) and the rest as escapes, an eighth of the bytes
// to read. Raw: the floats under zstd (lossless peer).
// Layout and error bound: docs/remote-protocol.md, "Disparity, q16" and "q16-packed".
//
// The pixel loops are per-ISA kernels (disparity_kernels.inl); the pixel-by-pixel form of the
// same arithmetic is disparity_q16_reference.cpp, and the white-box tests hold the two equal
// byte for byte.

#include <cmath>
#include <cstring>
#include <memory>
#include <span>

#include <fmt/format.h>

#include "disparity_kernels.h"
#include "disparity_q16_codes.h"

namespace plx::remote {

using q16::quantStep;

DisparityRange disparityRange(const Image<float>& disparity) {
    using namespace detail;
    const PositiveRange r = PLX_ISA_PICK(positiveRange)(disparity.data(), disparity.pixelCount());
    return r.hi > 0.0f ? DisparityRange{r.lo, r.hi} : DisparityRange{};
}

DisparityRange disparityRangeInRows(const Image<float>& disparity, std::span<const float> rowMin,
                                    std::span<const float> rowMax, bool* inside) {
    using namespace detail;
    PLX_CHECK(rowMin.size() == size_t(disparity.height()) &&
              rowMax.size() == size_t(disparity.height()));
    int64_t outside = 0;
    const PositiveRange r =
        PLX_ISA_PICK(positiveRangeInRows)(disparity.data(), disparity.width(), disparity.height(),
                                          rowMin.data(), rowMax.data(), &outside);
    *inside = outside == 0;
    return r.hi > 0.0f ? DisparityRange{r.lo, r.hi} : DisparityRange{};
}

size_t packedSymbolBytes(int width, int height) {
    return q16::packedRowBytes(width) * size_t(height);
}

Result<size_t> packedEscapeCount(std::span<const uint8_t> in, int width, int height) {
    const Result<uint64_t> content = zstdFrameContentSize(in, "disparity");
    if (!content) return content.status();
    const uint64_t symbols = packedSymbolBytes(width, height);
    const uint64_t most = symbols + 2 * uint64_t(width) * uint64_t(height);
    if (*content < symbols || *content > most || (*content - symbols) % 2 != 0) {
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("disparity: zstd frame of {} bytes, not {} symbol bytes "
                                       "and whole escapes (at most {} bytes)",
                                       *content, symbols, most));
    }
    return size_t((*content - symbols) / 2);
}

namespace {

Status encodePacked(const Image<float>& disparity, DisparityRange range, int level,
                    std::vector<uint8_t>* out) {
    using namespace detail;
    const int w = disparity.width(), h = disparity.height();
    std::vector<uint16_t> codes(static_cast<size_t>(w));
    std::vector<uint8_t> low(static_cast<size_t>(w)), high(static_cast<size_t>(w));
    // The frame's bytes: the symbols, then room for every pixel's escape (written by the kernel
    // before zstd reads them; untouched pages cost nothing).
    const size_t symbolBytes = packedSymbolBytes(w, h);
    const std::unique_ptr<uint8_t[]> bytes(new uint8_t[symbolBytes + 2 * disparity.pixelCount()]);
    const size_t escapes = PLX_ISA_PICK(encodeQ16Packed)(
        disparity.data(), w, h, range.dmin, q16::inverseQuantStep(range), codes.data(), low.data(),
        high.data(), bytes.get(), bytes.get() + symbolBytes);
    return zstdCompress({bytes.get(), symbolBytes + 2 * escapes}, level, out);
}

Status decodePacked(std::span<const uint8_t> in, DisparityRange range,
                    std::span<const float> rowMin, std::span<const float> rowMax,
                    Image<float>* disparity) {
    using namespace detail;
    const int w = disparity->width(), h = disparity->height();
    const Result<size_t> escapes = packedEscapeCount(in, w, h);
    if (!escapes) return escapes.status();
    const size_t symbolBytes = packedSymbolBytes(w, h), size = symbolBytes + 2 * *escapes;
    const std::unique_ptr<uint8_t[]> bytes(new uint8_t[size]);
    PLX_RETURN_IF_ERROR(zstdDecompressExact(in, {bytes.get(), size}, "disparity"));
    std::vector<uint16_t> codes(static_cast<size_t>(w));
    std::vector<uint8_t> low(static_cast<size_t>(w)), high(static_cast<size_t>(w));
    const ptrdiff_t used = PLX_ISA_PICK(decodeQ16Packed)(
        bytes.get(), bytes.get() + symbolBytes, *escapes, w, h, range.dmin, quantStep(range),
        rowMin.data(), rowMax.data(), codes.data(), low.data(), high.data(), disparity->data());
    return checkEscapesUsed(*escapes, used);
}

}  // namespace

Status checkEscapesUsed(size_t escapes, ptrdiff_t used) {
    if (used < 0)
        return {ErrorCode::kCorruptData,
                fmt::format("disparity: {} escapes, fewer than its symbols ask for", escapes)};
    if (size_t(used) != escapes)
        return {ErrorCode::kCorruptData, fmt::format("disparity: {} escapes, {} left over", escapes,
                                                     escapes - size_t(used))};
    return {};
}

Status encodeDisparityQ16(const Image<float>& disparity, DisparityRange range, DisparityCodec codec,
                          int level, std::vector<uint8_t>* out) {
    using namespace detail;
    if (codec == DisparityCodec::kQuantized16Packed)
        return encodePacked(disparity, range, level, out);
    const int w = disparity.width(), h = disparity.height();
    const size_t n = disparity.pixelCount();
    std::vector<uint16_t> codes(static_cast<size_t>(w));
    // Low bytes of every residual, then high bytes; the kernel writes each byte, so no fill.
    const std::unique_ptr<uint8_t[]> planes(new uint8_t[2 * n]);
    const auto encodePlanes = PLX_ISA_PICK(encodeQ16Planes);
    encodePlanes(disparity.data(), w, h, range.dmin, q16::inverseQuantStep(range), codes.data(),
                 planes.get());
    const std::span<const uint8_t> bytes(planes.get(), 2 * n);
    return codec == DisparityCodec::kQuantized16Deflate ? zlibCompress(bytes, level, out)
                                                        : zstdCompress(bytes, level, out);
}

Status decodeDisparityQ16(std::span<const uint8_t> in, DisparityCodec codec, DisparityRange range,
                          std::span<const float> rowMin, std::span<const float> rowMax,
                          Image<float>* disparity) {
    using namespace detail;
    if (codec == DisparityCodec::kQuantized16Packed)
        return decodePacked(in, range, rowMin, rowMax, disparity);
    const int w = disparity->width(), h = disparity->height();
    // Both decompressors fill every byte or fail, so no fill beforehand.
    const size_t planeBytes = 2 * disparity->pixelCount();
    const std::unique_ptr<uint8_t[]> owner(new uint8_t[planeBytes]);
    const std::span<uint8_t> planes(owner.get(), planeBytes);
    PLX_RETURN_IF_ERROR(codec == DisparityCodec::kQuantized16Deflate
                            ? zlibInflateExact(in, planes, "disparity")
                            : zstdDecompressExact(in, planes, "disparity"));
    std::vector<uint16_t> codes(static_cast<size_t>(w));
    const auto decodePlanes = PLX_ISA_PICK(decodeQ16Planes);
    decodePlanes(planes.data(), w, h, range.dmin, quantStep(range), rowMin.data(), rowMax.data(),
                 codes.data(), disparity->data());
    return {};
}

Status encodeDisparityRaw(const Image<float>& disparity, int level, std::vector<uint8_t>* out) {
    std::vector<uint8_t> bytes(disparity.pixelCount() * 4);
    std::memcpy(bytes.data(), disparity.data(), bytes.size());  // x86-64 and ARM: little-endian
    return zstdCompress(bytes, level, out);
}

Status decodeDisparityRaw(std::span<const uint8_t> in, std::span<const float> rowMin,
                          std::span<const float> rowMax, Image<float>* disparity) {
    std::vector<uint8_t> bytes(disparity->pixelCount() * 4);
    PLX_RETURN_IF_ERROR(zstdDecompressExact(in, bytes, "disparity"));
    std::memcpy(disparity->data(), bytes.data(), bytes.size());
    for (int y = 0; y < disparity->height(); ++y) {
        const float* row = disparity->row(y);
        for (int x = 0; x < disparity->width(); ++x) {
            const float d = row[x];
            if (!(d >= rowMin[size_t(y)] && d <= rowMax[size_t(y)])) {  // NaN fails too
                return {ErrorCode::kCorruptData,
                        fmt::format("disparity ({}, {}) = {} outside its row's range [{}, {}]", x,
                                    y, d, rowMin[size_t(y)], rowMax[size_t(y)])};
            }
        }
    }
    return {};
}

}  // namespace plx::remote
