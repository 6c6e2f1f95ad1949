#include <fmt/format.h>

#include <plx/stereo/layout.h>

namespace plx::stereo {

Result<Layout> parseLayout(const std::string& name) {
    if (name == "pair") return Layout::kPair;
    if (name == "sbs") return Layout::kSideBySide;
    if (name == "tb") return Layout::kTopBottom;
    if (name == "anaglyph") return Layout::kAnaglyph;
    if (name == "interleaved") return Layout::kInterleaved;
    return errorStatus(ErrorCode::kInvalidArgument,
                       fmt::format("unknown stereo format '{}' (pair, sbs, tb, anaglyph, "
                                   "interleaved)", name));
}

const char* layoutName(Layout layout) {
    switch (layout) {
        case Layout::kPair: return "pair";
        case Layout::kSideBySide: return "sbs";
        case Layout::kTopBottom: return "tb";
        case Layout::kAnaglyph: return "anaglyph";
        case Layout::kInterleaved: return "interleaved";
    }
    return "unknown";
}

Image<Rgba8> composeStereo(const Image<Rgba8>& left, const Image<Rgba8>& right, Layout layout) {
    PLX_CHECK(left.width() == right.width() && left.height() == right.height());
    PLX_CHECK(layout != Layout::kPair);
    const int w = left.width(), h = left.height();
    switch (layout) {
        case Layout::kSideBySide: {
            Image<Rgba8> out(2 * w, h);
            for (int y = 0; y < h; ++y) {
                std::copy_n(left.row(y), w, out.row(y));
                std::copy_n(right.row(y), w, out.row(y) + w);
            }
            return out;
        }
        case Layout::kTopBottom: {
            Image<Rgba8> out(w, 2 * h);
            for (int y = 0; y < h; ++y) {
                std::copy_n(left.row(y), w, out.row(y));
                std::copy_n(right.row(y), w, out.row(y + h));
            }
            return out;
        }
        case Layout::kAnaglyph: {
            // Colour anaglyph for red (left) / cyan (right) glasses.
            Image<Rgba8> out(w, h);
            for (size_t i = 0; i < out.pixelCount(); ++i) {
                const Rgba8 l = left.data()[i], r = right.data()[i];
                out.data()[i] = {l.r, r.g, r.b, 255};
            }
            return out;
        }
        default: {
            // Fig. 2: one frame buffer holding both images in alternate rows (fields).
            Image<Rgba8> out(w, h);
            for (int y = 0; y < h; ++y) std::copy_n((y % 2 ? right : left).row(y), w, out.row(y));
            return out;
        }
    }
}

}  // namespace plx::stereo
