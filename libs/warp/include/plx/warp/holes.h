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
// it filled. Preconditions: the three images have the same size; depth holds 1/w (0 = far).
int64_t fillRearSurface(Image<Rgba8>* color, Image<float>* depth, Image<uint8_t>* holeMask,
                        Rgba8 clearColor);

// The fill of one row of `w` pixels, as above: returns how many it filled, or -1 when the row
// has no covered pixel (left as it is, for fillEmptyRows). The warper runs it on each band of
// rows while they are still in cache.
int fillRowRearSurface(Rgba8* color, float* depth, uint8_t* holeMask, int w);

// The second step: every row still wholly a hole (mask 1 at its first pixel after the row
// fill) copies the nearest row that is not, or takes the clear colour. Returns pixels filled.
int64_t fillEmptyRows(Image<Rgba8>* color, Image<float>* depth, Image<uint8_t>* holeMask,
                      Rgba8 clearColor);

}  // namespace plx::warp
