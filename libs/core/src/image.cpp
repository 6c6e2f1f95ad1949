#include <plx/core/image.h>

namespace plx {

Image<Rgba8> toRgba8(const ByteImage& src) {
    PLX_CHECK(src.channels >= 1 && src.channels <= 4 && src.width >= 0 && src.height >= 0);
    PLX_CHECK(src.bytes.size() == src.rowBytes() * size_t(src.height));
    Image<Rgba8> out(src.width, src.height);
    for (int y = 0; y < src.height; ++y) {
        for (int x = 0; x < src.width; ++x) {
            const uint8_t* p = src.pixel(x, y);
            Rgba8& o = out.at(x, y);
            switch (src.channels) {
                case 1: o = {p[0], p[0], p[0], 255}; break;
                case 2: o = {p[0], p[0], p[0], p[1]}; break;
                case 3: o = {p[0], p[1], p[2], 255}; break;
                default: o = {p[0], p[1], p[2], p[3]}; break;
            }
        }
    }
    return out;
}

ByteImage fromRgba8(const Image<Rgba8>& src, int channels) {
    PLX_CHECK(channels >= 1 && channels <= 4);
    ByteImage out{src.width(), src.height(), channels, {}};
    out.bytes.resize(size_t(src.width()) * size_t(src.height()) * size_t(channels));
    for (int y = 0; y < src.height(); ++y) {
        for (int x = 0; x < src.width(); ++x) {
            const Rgba8& c = src.at(x, y);
            uint8_t* p = out.pixel(x, y);
            // Rec. 709 luma weights in 8-bit fixed point (54 + 183 + 19 = 256).
            uint8_t luma = uint8_t((54 * c.r + 183 * c.g + 19 * c.b + 128) >> 8);
            switch (channels) {
                case 1: p[0] = luma; break;
                case 2: p[0] = luma; p[1] = c.a; break;
                case 3: p[0] = c.r; p[1] = c.g; p[2] = c.b; break;
                default: p[0] = c.r; p[1] = c.g; p[2] = c.b; p[3] = c.a; break;
            }
        }
    }
    return out;
}

}  // namespace plx
