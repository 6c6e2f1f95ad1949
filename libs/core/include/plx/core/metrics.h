#pragma once
// Image comparison metrics used by tests, the stereo quality report and experiments.

#include <cstdint>

#include <plx/core/image.h>

namespace plx {

struct ImageDiffStats {
    double psnrDb = 0.0;             // over RGB, peak 255; +infinity when identical
    double meanAbsoluteError = 0.0;  // mean over RGB channels of |a - b|, in 8-bit units
    int64_t differingPixels = 0;     // pixels whose RGB differs by more than the tolerance
    int maxChannelDifference = 0;
};

// Compares RGB of two images of the same size. tolerance: a pixel counts as differing when any
// channel differs by more than this. Precondition: same size.
ImageDiffStats compareImages(const Image<Rgba8>& a, const Image<Rgba8>& b, int tolerance = 0);

// PSNR in dB over RGB (peak 255); +infinity for identical images. Precondition: same size.
double psnr(const Image<Rgba8>& a, const Image<Rgba8>& b);

// Visual diff: black where equal, the absolute difference amplified by `gain` elsewhere, and
// pure magenta where any channel differs by more than highlightAbove. Precondition (checked,
// abort): same size.
Image<Rgba8> diffImage(const Image<Rgba8>& a, const Image<Rgba8>& b, float gain = 4.0f,
                       int highlightAbove = 255);

}  // namespace plx
