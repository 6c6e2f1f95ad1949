#pragma once
// Reference-view and reference-set payloads for the wire (Mark, Bishop, McMillan, "Compression of
// Transmitted Data": "conventional image compression techniques should be effective on the color
// portion of the image ... the disparity values should be highly compressible as well").
// Colour: JPEG through TurboJPEG, or zstd of raw RGB (lossless). Disparity: 16-bit quantised,
// predicted along rows by second differences and coded with zstd (or zlib, for browsers), or
// zstd of the raw floats.
// The byte layout, the quantisation and its error bound are in docs/remote-protocol.md;
// measurements behind the defaults in docs/remote-results.md.

#include <cstdint>
#include <span>
#include <vector>

#include <plx/core/status.h>
#include <plx/warp/warp.h>

namespace plx::remote {

enum class ColorCodec : uint8_t { kJpeg = 1, kZstd = 2 };
// kQuantized16Deflate: q16's codes and planes, compressed as one zlib stream instead of zstd, for
// clients without zstd (browsers: DecompressionStream inflates deflate, not zstd).
// kQuantized16Packed: q16's codes and residuals, most of them 0 or +-1, as two-bit symbols under
// zstd plus escapes: zstd reads an eighth of the planes' bytes (docs/remote-protocol.md).
enum class DisparityCodec : uint8_t {
    kQuantized16 = 1,
    kFloatZstd = 2,
    kQuantized16Deflate = 3,
    kQuantized16Packed = 4,
};
enum class ChromaSubsampling { k420, k444 };

struct CodecOptions {
    ColorCodec color = ColorCodec::kJpeg;
    // JPEG quality 1..100. 90 with 4:2:0: see docs/remote-results.md for the bytes and warped
    // PSNR of each choice.
    int jpegQuality = 90;
    ChromaSubsampling chroma = ChromaSubsampling::k420;
    DisparityCodec disparity = DisparityCodec::kQuantized16Packed;
    // zstd level 1..19 for every zstd payload. 1: on q16-packed's symbols level 3 saves under 1%
    // of a 1280x720 session's set for 2 ms more encode and fewer sets per second
    // (docs/remote-results.md).
    int zstdLevel = 1;
    // zlib level 1..9 for the q16-deflate payload (6, zlib's default: see
    // docs/remote-results.md).
    int deflateLevel = 6;
};

// What a decoder accepts; everything larger is refused before allocation.
struct DecodeLimits {
    int maxViewSide = 4096;  // width and height of a view
    int64_t maxViewPixels = int64_t(4096) * 4096;
    int maxViews = 6;  // views per set (cube6)
    int64_t maxSetPixels = int64_t(6) * 4096 * 4096;
};

constexpr uint8_t kCodecVersion = 1;

// Encodes one view. Preconditions (errors otherwise, kInvalidArgument): colour and disparity of
// the camera's size, row ranges of its height with 0 <= min <= max, finite, every disparity
// within its row's range (computeRowDisparityRange makes them so), sides <= 65535, options in
// range.
Result<std::vector<uint8_t>> encodeReferenceView(const warp::ReferenceView& view,
                                                 const CodecOptions& options);

// Decodes one view from untrusted bytes into *out (reusing its buffers). Errors name the field.
Status decodeReferenceView(std::span<const uint8_t> bytes, const DecodeLimits& limits,
                           warp::ReferenceView* out);

// Encodes a set: its pose, render time and every view. Errors: as encodeReferenceView, a set
// with no views or more than 255, a pose checkPose refuses.
Result<std::vector<uint8_t>> encodeReferenceSet(const warp::ReferenceSet& set,
                                                const CodecOptions& options);

// Decodes a set from untrusted bytes into *out. Errors name the view and the field.
Status decodeReferenceSet(std::span<const uint8_t> bytes, const DecodeLimits& limits,
                          warp::ReferenceSet* out);

// The q16 disparity error bound of a view: half a quantisation step, (dmax - dmin) / 65534 / 2,
// plus one float rounding of dmax; 0 for a view with no drawn pixel.
float disparityErrorBound(const Image<float>& disparity);

}  // namespace plx::remote
