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
const float* srgbDecodeTable();  // [256]
uint8_t encodeSrgb8(float linear);

inline Vec3 decodeRgb(Rgba8 c) {
    const float* t = srgbDecodeTable();
    return {t[c.r], t[c.g], t[c.b]};
}
inline Rgba8 encodeRgb(const Vec3& linear, uint8_t alpha = 255) {
    return {encodeSrgb8(linear.r), encodeSrgb8(linear.g), encodeSrgb8(linear.b), alpha};
}

}  // namespace plx
