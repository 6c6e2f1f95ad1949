// The q16 disparity codec and the disparity range written pixel by pixel, as
// docs/remote-protocol.md states them: the reference the per-ISA kernels of disparity_q16.cpp
// (disparity_kernels.inl) must equal byte for byte (white-box tests) and are timed against
// (benches).

#include <algorithm>
#include <cmath>

#include "disparity_q16_codes.h"

namespace plx::remote::reference {
using q16::predict;
using q16::quantStep;
using q16::unzigzag;
using q16::zigzag;

// q16-packed from q16's planes: per pixel the symbol min(z, 3) at bits 2 (x mod 4) of its row's
// byte x / 4, then each z >= 3 as an escape, all in one zstd frame.
Status packQ16Planes(const std::vector<uint8_t>& planes, int w, int h, int level,
                     std::vector<uint8_t>* out) {
    const size_t n = size_t(w) * size_t(h), rowBytes = q16::packedRowBytes(w);
    std::vector<uint8_t> symbols(rowBytes * size_t(h), 0), escapes;
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const size_t i = size_t(y) * size_t(w) + size_t(x);
            const int z = planes[i] | planes[n + i] << 8;
            symbols[size_t(y) * rowBytes + size_t(x) / 4] |=
                uint8_t(std::min(z, 3) << (2 * (x % 4)));
            if (z >= 3) escapes.insert(escapes.end(), {planes[i], planes[n + i]});
        }
    }
    symbols.insert(symbols.end(), escapes.begin(), escapes.end());
    return zstdCompress(symbols, level, out);
}

namespace {

// The reverse, into q16's planes.
Status unpackPlanes(std::span<const uint8_t> in, int w, int h, std::vector<uint8_t>* planes) {
    const Result<size_t> escapes = packedEscapeCount(in, w, h);
    if (!escapes) return escapes.status();
    const size_t n = size_t(w) * size_t(h), rowBytes = q16::packedRowBytes(w);
    const size_t symbolBytes = rowBytes * size_t(h);
    std::vector<uint8_t> bytes(symbolBytes + 2 * *escapes);
    PLX_RETURN_IF_ERROR(zstdDecompressExact(in, bytes, "disparity"));
    size_t used = 0;
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const size_t i = size_t(y) * size_t(w) + size_t(x);
            const int symbol = bytes[size_t(y) * rowBytes + size_t(x) / 4] >> (2 * (x % 4)) & 3;
            (*planes)[i] = uint8_t(symbol);
            (*planes)[n + i] = 0;
            if (symbol < 3) continue;
            if (used == *escapes) return checkEscapesUsed(*escapes, -1);
            (*planes)[i] = bytes[symbolBytes + 2 * used];
            (*planes)[n + i] = bytes[symbolBytes + 2 * used + 1];
            ++used;
        }
    }
    return checkEscapesUsed(*escapes, ptrdiff_t(used));
}

}  // namespace

DisparityRange disparityRange(const Image<float>& disparity) {
    DisparityRange r{0.0f, 0.0f};
    float lo = INFINITY;
    for (size_t i = 0; i < disparity.pixelCount(); ++i) {
        const float d = disparity.data()[i];
        if (d > 0.0f) lo = std::min(lo, d);
        r.dmax = std::max(r.dmax, d);
    }
    r.dmin = r.dmax > 0.0f ? lo : 0.0f;
    return r;
}

Status encodeDisparityQ16(const Image<float>& disparity, DisparityRange range, DisparityCodec codec,
                          int level, std::vector<uint8_t>* out) {
    const int w = disparity.width(), h = disparity.height();
    const size_t n = disparity.pixelCount();
    const double step = quantStep(range);
    std::vector<uint16_t> q(static_cast<size_t>(w));
    std::vector<uint8_t> planes(2 * n);  // low bytes of every residual, then high bytes
    int aboveFirst = 0;
    for (int y = 0; y < h; ++y) {
        const float* src = disparity.row(y);
        for (int x = 0; x < w; ++x) {
            const double d = src[x];
            // Clamped to 1..65535; a NaN (which std::clamp would pass through) takes code 1.
            const double code =
                step > 0.0 ? 1.0 + std::floor((d - range.dmin) * (1.0 / step) + 0.5) : 1.0;
            q[size_t(x)] = d == 0.0 ? 0 : uint16_t(code >= 1.0 ? std::min(code, 65535.0) : 1.0);
        }
        for (int x = 0; x < w; ++x) {
            const uint16_t z = zigzag(int(q[size_t(x)]) - predict(q.data(), x, aboveFirst));
            const size_t i = size_t(y) * size_t(w) + size_t(x);
            planes[i] = uint8_t(z);
            planes[n + i] = uint8_t(z >> 8);
        }
        aboveFirst = q[0];
    }
    if (codec == DisparityCodec::kQuantized16Packed) return packQ16Planes(planes, w, h, level, out);
    return codec == DisparityCodec::kQuantized16Deflate ? zlibCompress(planes, level, out)
                                                        : zstdCompress(planes, level, out);
}

Status decodeDisparityQ16(std::span<const uint8_t> in, DisparityCodec codec, DisparityRange range,
                          std::span<const float> rowMin, std::span<const float> rowMax,
                          Image<float>* disparity) {
    const int w = disparity->width(), h = disparity->height();
    const size_t n = disparity->pixelCount();
    std::vector<uint8_t> planes(2 * n);
    if (codec == DisparityCodec::kQuantized16Packed) {
        PLX_RETURN_IF_ERROR(unpackPlanes(in, w, h, &planes));
    } else {
        PLX_RETURN_IF_ERROR(codec == DisparityCodec::kQuantized16Deflate
                                ? zlibInflateExact(in, planes, "disparity")
                                : zstdDecompressExact(in, planes, "disparity"));
    }
    const double step = quantStep(range);
    std::vector<uint16_t> q(static_cast<size_t>(w));
    int aboveFirst = 0;
    for (int y = 0; y < h; ++y) {
        float* dst = disparity->row(y);
        for (int x = 0; x < w; ++x) {
            const size_t i = size_t(y) * size_t(w) + size_t(x);
            const auto z = uint16_t(planes[i] | (planes[n + i] << 8));
            q[size_t(x)] = uint16_t(predict(q.data(), x, aboveFirst) + unzigzag(z));
            const uint16_t c = q[size_t(x)];
            // Clamped to the row's exact range so that the warp's row clipping stays true.
            dst[x] = c == 0 ? 0.0f
                            : std::clamp(float(double(range.dmin) + double(c - 1) * step),
                                         rowMin[size_t(y)], rowMax[size_t(y)]);
        }
        aboveFirst = q[0];
    }
    return {};
}

}  // namespace plx::remote::reference
