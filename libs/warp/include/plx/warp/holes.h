#pragma once
// Holes (Mark, Bishop, McMillan, "Improving Quality of Final Images"): what several references
// composited by depth leave uncovered is filled by the rear-surface guess: "fill in the gap with
// the color of the nearest pixel from the rear surface", assuming the surface behind the front
// object continues. Along each destination row, a run of hole pixels takes the colour and depth
// of the covered pixel at whichever end of the run is farther (smaller 1/w); a run touching the
// image border takes its one neighbour; a row with no covered pixel takes the nearest filled
// row's pixel above or below (or the clear colour when nothing at all was covered).

#include <cstdint>

#include <plx/core/image.h>

namespace plx::warp {

// Fills every pixel whose mask is 1 (a hole) as above and sets its mask to 2. Returns how many
// it filled. rowHoles, when given, holds each row's count of holes (rows with none are passed
// over). Preconditions: the three images have the same size; depth holds 1/w (0 = far).
int64_t fillRearSurface(Image<Rgba8>* color, Image<float>* depth, Image<uint8_t>* holeMask,
                        Rgba8 clearColor, const int* rowHoles = nullptr);

}  // namespace plx::warp
