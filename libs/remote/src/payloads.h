#pragma once
// The colour and disparity payloads of an encoded reference view (docs/remote-protocol.md,
// "Encoded reference view"). Decoders take untrusted bytes and an output already sized by the
// view header (whose limits were checked before it was allocated).

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include <plx/core/image.h>
#include <plx/core/status.h>
#include <plx/remote/codec.h>

namespace plx::remote {

// zstd: compresses `in` as one frame with its content size recorded.
Status zstdCompress(std::span<const uint8_t> in, int level, std::vector<uint8_t>* out);
// Checks, without decompressing, that `in` is exactly one zstd frame with its content size
// recorded, and returns that size.
Result<uint64_t> zstdFrameContentSize(std::span<const uint8_t> in, const char* field);
// The same, and that the recorded content size is `expected`.
Status checkZstdFrame(std::span<const uint8_t> in, size_t expected, const char* field);
// Decompresses one zstd frame whose recorded content size must be exactly out.size(). field
// names the payload in errors.
Status zstdDecompressExact(std::span<const uint8_t> in, std::span<uint8_t> out, const char* field);

// zlib (RFC 1950): compresses `in` as one stream.
Status zlibCompress(std::span<const uint8_t> in, int level, std::vector<uint8_t>* out);
// Checks, without inflating, a zlib stream's header: deflate, window <= 32 KiB, no dictionary.
Status checkZlibHeader(std::span<const uint8_t> in, const char* field);
// Inflates one zlib stream that must produce exactly out.size() bytes and end with the input.
Status zlibInflateExact(std::span<const uint8_t> in, std::span<uint8_t> out, const char* field);

// Colour as JPEG (TurboJPEG, alpha dropped) or zstd of raw RGB.
Status encodeColor(const Image<Rgba8>& color, const CodecOptions& options,
                   std::vector<uint8_t>* out);
// Checks a colour payload's header (JPEG size, zstd content size) against the view's size before
// anything is allocated for it.
Status checkColorHeader(ColorCodec codec, std::span<const uint8_t> in, int width, int height);
// Decodes into *color, already of the view's size; alpha becomes 255.
Status decodeColor(ColorCodec codec, std::span<const uint8_t> in, Image<Rgba8>* color);

// The smallest non-zero and the largest disparity of a view (both 0 when nothing is drawn).
struct DisparityRange {
    float dmin = 0.0f;
    float dmax = 0.0f;
};
DisparityRange disparityRange(const Image<float>& disparity);
// The same in one pass with checkView's pixel test (each pixel within its row's [rowMin, rowMax],
// NaN outside): false in *inside when a pixel is not, and the range is then meaningless.
DisparityRange disparityRangeInRows(const Image<float>& disparity, std::span<const float> rowMin,
                                    std::span<const float> rowMax, bool* inside);

// q16: quantised, row-predicted residual planes (docs/remote-protocol.md, "Disparity, q16"),
// compressed with zstd (kQuantized16) or zlib (kQuantized16Deflate) at `level`; or the same
// residuals as two-bit symbols under zstd and escapes (kQuantized16Packed).
Status encodeDisparityQ16(const Image<float>& disparity, DisparityRange range,
                          DisparityCodec codec, int level, std::vector<uint8_t>* out);
// Decodes into *disparity, already of the view's size, clamping each drawn pixel to its row's
// range (rowMin, rowMax: one entry per row).
Status decodeDisparityQ16(std::span<const uint8_t> in, DisparityCodec codec, DisparityRange range,
                          std::span<const float> rowMin, std::span<const float> rowMax,
                          Image<float>* disparity);

// q16-packed's payload (docs/remote-protocol.md, "Disparity, q16-packed"): one zstd frame of the
// symbols (packedSymbolBytes) followed by the escapes (2 bytes each).
// packedEscapeCount checks, without decompressing, the frame and its recorded size against a
// width x height view, and returns the escape count it implies.
Result<size_t> packedEscapeCount(std::span<const uint8_t> in, int width, int height);
// Bytes of the symbols of a width x height view: ceil(width / 4) a row.
size_t packedSymbolBytes(int width, int height);
// The decoder's escape count against the escapes it used (-1: a row asked for more than were
// left): an error naming the mismatch, or ok.
Status checkEscapesUsed(size_t escapes, ptrdiff_t used);

// The pixel-by-pixel forms of the three above (disparity_q16_reference.cpp): what their per-ISA
// kernels must equal byte for byte (white-box tests) and are timed against (benches).
namespace reference {
DisparityRange disparityRange(const Image<float>& disparity);
Status encodeDisparityQ16(const Image<float>& disparity, DisparityRange range, DisparityCodec codec,
                          int level, std::vector<uint8_t>* out);
Status decodeDisparityQ16(std::span<const uint8_t> in, DisparityCodec codec, DisparityRange range,
                          std::span<const float> rowMin, std::span<const float> rowMax,
                          Image<float>* disparity);
// A q16-packed payload from q16's residual planes (2 w h bytes, low then high).
Status packQ16Planes(const std::vector<uint8_t>& planes, int w, int h, int level,
                     std::vector<uint8_t>* out);
}  // namespace reference

// Raw: zstd of the little-endian floats; decoding checks each is finite, >= 0 and in its row's
// range.
Status encodeDisparityRaw(const Image<float>& disparity, int level, std::vector<uint8_t>* out);
Status decodeDisparityRaw(std::span<const uint8_t> in, std::span<const float> rowMin,
                          std::span<const float> rowMax, Image<float>* disparity);

}  // namespace plx::remote
