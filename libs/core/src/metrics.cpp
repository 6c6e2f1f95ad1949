#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

#include <plx/core/metrics.h>

namespace plx {

ImageDiffStats compareImages(const Image<Rgba8>& a, const Image<Rgba8>& b, int tolerance) {
    PLX_CHECK(a.width() == b.width() && a.height() == b.height());
    ImageDiffStats s;
    double sumSq = 0.0, sumAbs = 0.0;
    for (size_t i = 0; i < a.pixelCount(); ++i) {
        const Rgba8 p = a.data()[i], q = b.data()[i];
        int d[3] = {std::abs(p.r - q.r), std::abs(p.g - q.g), std::abs(p.b - q.b)};
        int m = std::max({d[0], d[1], d[2]});
        s.maxChannelDifference = std::max(s.maxChannelDifference, m);
        if (m > tolerance) ++s.differingPixels;
        for (int c : d) {
            sumSq += double(c) * c;
            sumAbs += c;
        }
    }
    double samples = 3.0 * double(std::max<size_t>(a.pixelCount(), 1));
    s.meanAbsoluteError = sumAbs / samples;
    double mse = sumSq / samples;
    s.psnrDb = mse == 0.0 ? std::numeric_limits<double>::infinity()
                          : 10.0 * std::log10(255.0 * 255.0 / mse);
    return s;
}

double psnr(const Image<Rgba8>& a, const Image<Rgba8>& b) { return compareImages(a, b).psnrDb; }

Image<Rgba8> diffImage(const Image<Rgba8>& a, const Image<Rgba8>& b, float gain,
                       int highlightAbove) {
    PLX_CHECK(a.width() == b.width() && a.height() == b.height());
    Image<Rgba8> out(a.width(), a.height(), Rgba8{0, 0, 0, 255});
    for (size_t i = 0; i < a.pixelCount(); ++i) {
        const Rgba8 p = a.data()[i], q = b.data()[i];
        int d[3] = {std::abs(p.r - q.r), std::abs(p.g - q.g), std::abs(p.b - q.b)};
        if (std::max({d[0], d[1], d[2]}) > highlightAbove) {
            out.data()[i] = {255, 0, 255, 255};
            continue;
        }
        auto amp = [gain](int v) { return uint8_t(std::min(255.0f, float(v) * gain)); };
        out.data()[i] = {amp(d[0]), amp(d[1]), amp(d[2]), 255};
    }
    return out;
}

}  // namespace plx
