#pragma once
// sRGB <-> linear conversions. Shading works in linear float RGB; targets and files hold sRGB.

#include <cstdint>

#include <plx/core/image.h>
#include <plx/core/math.h>

namespace plx {

// Exact sRGB transfer functions (IEC 61966-2-1).
float srgbToLinear(float encoded);
float linearToSrgb(float linear);

// Table lookups for the hot paths: 256 entries decode a byte; 4096 entries encode [0,1].
constexpr int kSrgbEncodeEntries = 4096;
const float* srgbDecodeTable();    // [256]
const uint8_t* srgbEncodeTable();  // [kSrgbEncodeEntries + 1]
uint8_t encodeSrgb8(float linear);

// encodeSrgb8 with the table fetched by the caller (hot loops fetch it once).
inline uint8_t encodeSrgb8(float linear, const uint8_t* encodeTable) {
    // NaN compares false and lands on 0 through the first test.
    if (!(linear > 0.0f)) return 0;
    if (linear >= 1.0f) return 255;
    return encodeTable[int(linear * float(kSrgbEncodeEntries) + 0.5f)];
}

inline Vec3 decodeRgb(Rgba8 c) {
    const float* t = srgbDecodeTable();
    return {t[c.r], t[c.g], t[c.b]};
}
inline Rgba8 encodeRgb(const Vec3& linear, uint8_t alpha = 255) {
    const uint8_t* t = srgbEncodeTable();
    return {encodeSrgb8(linear.r, t), encodeSrgb8(linear.g, t), encodeSrgb8(linear.b, t), alpha};
}

}  // namespace plx
