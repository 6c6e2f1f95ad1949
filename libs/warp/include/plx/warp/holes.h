#pragma once
// Holes (Mark, Bishop, McMillan, "Improving Quality of Final Images"): what several references
// composited by depth leave uncovered is filled by the rear-surface guess: "fill in the gap with
// the color of the nearest pixel from the rear surface", assuming the surface behind the front
// object continues. Along each destination row, a run of hole pixels takes the colour and depth
// of the covered pixel at whichever end of the run is farther (smaller 1/w); a run touching the
// image border takes its one neighbour; a row with no covered pixel takes the nearest filled
// row's pixel above or below (or the clear colour when nothing at all was covered).

#include <cstdint>
#include <span>
#include <vector>

#include <plx/core/camera.h>
#include <plx/core/image.h>

namespace plx::warp {

struct ReferenceSet;

// Compositing several sets (Mark, Bishop, McMillan, "Improving Quality of Final Images":
// "multiple source images ... to fill in the gaps left after warping the first image"). A plain
// z-buffer keeps the nearer of two samples even where both are the same surface: its flat splats
// are rebuilt from two viewpoints, so their 1/w differ by up to a splat's depth range and the
// winner is a coin toss between a close set's sharp sample and a far set's stretched one. So the
// set whose reference eye is nearest the destination eye (the first of equals in the given order)
// is preferred: every other set's destination 1/w is scaled by 1 / (1 + tolerance) before the
// z-test, and wins only where it is nearer by more than that relative margin (an occluder the
// preferred set does not show). The margin is relative in 1/w, one number for all splats; 30% came
// from a sweep (docs/warp-results.md): at 3% an exact newest set lost 3 dB to an older one on the
// office walk, at 30% 2 dB, and larger margins start to lose true occluders. A non-preferred
// pixel's written 1/w is the scaled one. Empty background (1/w = 0) cannot be ranked by any margin:
// another set's silhouette still covers the preferred set's background.
constexpr float kCompositeTolerance = 0.3f;

// Per set, the factor its destination 1/w is scaled by before the z-test: 1 for the preferred
// set, 1 / (1 + tolerance) for the others (tolerance <= 0: all 1, a plain z-buffer).
std::vector<float> compositeDepthScales(std::span<const ReferenceSet* const> sets,
                                        const Camera& destination, float tolerance);

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
