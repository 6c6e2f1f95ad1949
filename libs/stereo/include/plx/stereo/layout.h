#pragma once
// Stereo output layouts: separate images, side-by-side, top-bottom, red-cyan anaglyph, and the
// row-interleaved field-sequential frame of Heo, Jung, Wohn Fig. 2.

#include <string>

#include <plx/core/core.h>

namespace plx::stereo {

enum class Layout {
    kPair,         // two images (the caller writes left and right separately)
    kSideBySide,   // left | right, full resolution each (2W x H)
    kTopBottom,    // left over right (W x 2H)
    kAnaglyph,     // red from the left eye, green and blue from the right (W x H)
    kInterleaved,  // field-sequential: even rows from the left eye, odd rows from the right
};

Result<Layout> parseLayout(const std::string& name);
const char* layoutName(Layout layout);

// Composes one image from the two eyes. Precondition: same size; layout != kPair.
Image<Rgba8> composeStereo(const Image<Rgba8>& left, const Image<Rgba8>& right, Layout layout);

}  // namespace plx::stereo
