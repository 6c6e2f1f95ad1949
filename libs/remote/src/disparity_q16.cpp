// Disparity payloads. q16: the disparity delta = 1/w is affine in the pixel position across a
// plane seen in perspective, so along a row its second difference vanishes on every planar
// surface (the "highly compressible" disparity of Mark, Bishop, McMillan, citing Guenter et al.);
// quantised to 16 bits over the view's own range, predicted by 2a - b and zigzag-coded, the
// residuals are mostly 0 and +-1 and zstd (zlib for browsers) packs them. Raw: the floats under
// zstd (lossless peer).
// Layout and error bound: docs/remote-protocol.md, "Disparity, q16".

#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "payloads.h"

namespace plx::remote {
namespace {

// 65535 codes for drawn pixels: q = 1 + round((d - dmin) / step), 0 = nothing drawn.
constexpr double kSteps = 65534.0;

double quantStep(DisparityRange r) {
    return (double(r.dmax) - double(r.dmin)) / kSteps;
}

// The prediction of q[x] from the row so far (x >= 1) or the row above's first code (x == 0).
// Next to an empty pixel (q = 0) the plane predictor would extrapolate from "infinitely far", so
// the left neighbour is used alone.
inline int predict(const uint16_t* row, int x, int aboveFirst) {
    if (x == 0) return aboveFirst;
    const int a = row[x - 1];
    if (x == 1) return a;
    const int b = row[x - 2];
    if (a == 0 || b == 0) return a;
    return std::clamp(2 * a - b, 0, 65535);
}

inline uint16_t zigzag(int residual) {
    const auto r = int16_t(uint16_t(residual));  // (q - pred) mod 2^16, as signed
    return uint16_t((uint16_t(r) << 1) ^ uint16_t(r >> 15));
}

inline int unzigzag(uint16_t z) {
    return int(z >> 1) ^ -int(z & 1);
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

Status encodeDisparityQ16(const Image<float>& disparity, DisparityRange range,
                          DisparityCodec codec, int level, std::vector<uint8_t>* out) {
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
            q[size_t(x)] =
                d == 0.0 ? 0
                         : uint16_t(step > 0.0
                                        ? std::clamp(1.0 + std::nearbyint((d - range.dmin) / step),
                                                     1.0, 65535.0)
                                        : 1.0);
        }
        for (int x = 0; x < w; ++x) {
            const uint16_t z = zigzag(int(q[size_t(x)]) - predict(q.data(), x, aboveFirst));
            const size_t i = size_t(y) * size_t(w) + size_t(x);
            planes[i] = uint8_t(z);
            planes[n + i] = uint8_t(z >> 8);
        }
        aboveFirst = q[0];
    }
    return codec == DisparityCodec::kQuantized16Deflate ? zlibCompress(planes, level, out)
                                                        : zstdCompress(planes, level, out);
}

Status decodeDisparityQ16(std::span<const uint8_t> in, DisparityCodec codec, DisparityRange range,
                          std::span<const float> rowMin, std::span<const float> rowMax,
                          Image<float>* disparity) {
    const int w = disparity->width(), h = disparity->height();
    const size_t n = disparity->pixelCount();
    std::vector<uint8_t> planes(2 * n);
    PLX_RETURN_IF_ERROR(codec == DisparityCodec::kQuantized16Deflate
                            ? zlibInflateExact(in, planes, "disparity")
                            : zstdDecompressExact(in, planes, "disparity"));
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
