// Colour payloads: JPEG through TurboJPEG (the colour half of the paper's "conventional image
// compression"), or zstd of raw RGB as the lossless choice. Alpha is not sent: the renderer
// writes 255 everywhere and the warp ignores it.

#include <memory>

#include <turbojpeg.h>

#include <fmt/format.h>

#include "payloads.h"

namespace plx::remote {
namespace {

struct TjDeleter {
    void operator()(void* h) const { tjDestroy(h); }
};
using TjHandle = std::unique_ptr<void, TjDeleter>;

Status encodeJpeg(const Image<Rgba8>& color, const CodecOptions& o, std::vector<uint8_t>* out) {
    TjHandle tj(tjInitCompress());
    if (!tj) return {ErrorCode::kInternal, "TurboJPEG: cannot create a compressor"};
    const int samp = o.chroma == ChromaSubsampling::k444 ? TJSAMP_444 : TJSAMP_420;
    // Compress into an uninitialised buffer of the worst-case size (no TurboJPEG reallocation),
    // then copy the JPEG out: a vector of that size would first be cleared, four bytes a pixel
    // for a JPEG of a fraction of a byte a pixel.
    unsigned long size = tjBufSize(color.width(), color.height(), samp);
    const std::unique_ptr<unsigned char[]> jpeg(new unsigned char[size]);
    unsigned char* dst = jpeg.get();
    if (tjCompress2(tj.get(), reinterpret_cast<const unsigned char*>(color.data()), color.width(),
                    0, color.height(), TJPF_RGBX, &dst, &size, samp, o.jpegQuality,
                    TJFLAG_NOREALLOC) != 0) {
        return {ErrorCode::kInternal, fmt::format("TurboJPEG: {}", tjGetErrorStr2(tj.get()))};
    }
    out->assign(jpeg.get(), jpeg.get() + size);
    return {};
}

// The JPEG header's size against the view's.
Status checkJpegHeader(void* tj, std::span<const uint8_t> in, int width, int height) {
    int w = 0, h = 0, samp = 0, colorspace = 0;
    if (tjDecompressHeader3(tj, in.data(), in.size(), &w, &h, &samp, &colorspace) != 0) {
        return {ErrorCode::kCorruptData, fmt::format("colour JPEG header: {}", tjGetErrorStr2(tj))};
    }
    if (w != width || h != height) {
        return {ErrorCode::kCorruptData,
                fmt::format("colour JPEG is {}x{}, the view {}x{}", w, h, width, height)};
    }
    return {};
}

// Warnings (truncated data) are errors, and at most TurboJPEG's scan limit of progressive scans
// is decoded (a bound on decoding time).
Status decodeJpeg(std::span<const uint8_t> in, Image<Rgba8>* color) {
    TjHandle tj(tjInitDecompress());
    if (!tj) return {ErrorCode::kInternal, "TurboJPEG: cannot create a decompressor"};
    const int w = color->width(), h = color->height();
    PLX_RETURN_IF_ERROR(checkJpegHeader(tj.get(), in, w, h));
    if (tjDecompress2(tj.get(), in.data(), in.size(),
                      reinterpret_cast<unsigned char*>(color->data()), w, 0, h, TJPF_RGBA,
                      TJFLAG_STOPONWARNING | TJFLAG_LIMITSCANS) != 0) {
        return {ErrorCode::kCorruptData, fmt::format("colour JPEG: {}", tjGetErrorStr2(tj.get()))};
    }
    return {};
}

}  // namespace

Status encodeColor(const Image<Rgba8>& color, const CodecOptions& options,
                   std::vector<uint8_t>* out) {
    if (options.color == ColorCodec::kJpeg) return encodeJpeg(color, options, out);
    std::vector<uint8_t> rgb(color.pixelCount() * 3);
    for (size_t i = 0; i < color.pixelCount(); ++i) {
        rgb[3 * i] = color.data()[i].r;
        rgb[3 * i + 1] = color.data()[i].g;
        rgb[3 * i + 2] = color.data()[i].b;
    }
    return zstdCompress(rgb, options.zstdLevel, out);
}

Status checkColorHeader(ColorCodec codec, std::span<const uint8_t> in, int width, int height) {
    if (codec == ColorCodec::kZstd) return checkZstdFrame(in, size_t(width) * height * 3, "colour");
    TjHandle tj(tjInitDecompress());
    if (!tj) return {ErrorCode::kInternal, "TurboJPEG: cannot create a decompressor"};
    return checkJpegHeader(tj.get(), in, width, height);
}

Status decodeColor(ColorCodec codec, std::span<const uint8_t> in, Image<Rgba8>* color) {
    if (codec == ColorCodec::kJpeg) return decodeJpeg(in, color);
    std::vector<uint8_t> rgb(color->pixelCount() * 3);
    PLX_RETURN_IF_ERROR(zstdDecompressExact(in, rgb, "colour"));
    for (size_t i = 0; i < color->pixelCount(); ++i) {
        color->data()[i] = {rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2], 255};
    }
    return {};
}

}  // namespace plx::remote
