#include <array>
#include <cmath>

#include <plx/core/color.h>

namespace plx {

float srgbToLinear(float e) {
    return e <= 0.04045f ? e / 12.92f : std::pow((e + 0.055f) / 1.055f, 2.4f);
}

float linearToSrgb(float l) {
    return l <= 0.0031308f ? l * 12.92f : 1.055f * std::pow(l, 1.0f / 2.4f) - 0.055f;
}

namespace {
// 4096 entries over [0,1]: the encode error stays below half an 8-bit step except in the
// steepest part of the curve near black, where 12 bits of input still resolve every code.
constexpr int kEncodeEntries = kSrgbEncodeEntries;

struct Tables {
    std::array<float, 256> decode;
    std::array<uint8_t, kEncodeEntries + 1> encode;
    Tables() {
        for (int i = 0; i < 256; ++i) decode[i] = srgbToLinear(float(i) / 255.0f);
        for (int i = 0; i <= kEncodeEntries; ++i) {
            float v = linearToSrgb(float(i) / float(kEncodeEntries));
            encode[i] = uint8_t(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f));
        }
    }
};
const Tables& tables() {
    static const Tables t;
    return t;
}
}  // namespace

const float* srgbDecodeTable() { return tables().decode.data(); }

const uint8_t* srgbEncodeTable() { return tables().encode.data(); }

uint8_t encodeSrgb8(float linear) { return encodeSrgb8(linear, srgbEncodeTable()); }

}  // namespace plx
