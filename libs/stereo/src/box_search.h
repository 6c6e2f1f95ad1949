#pragma once
// The disocclusion search of FillSearch::kBoxHierarchy (fill.h): the box hierarchy walked
// nearest box first with the depth test deciding visibility, in place of the BSP order.

#include <span>

#include <plx/raster/raster.h>
#include <plx/raster/span_fill.h>
#include <plx/stereo/fill.h>

namespace plx::stereo {

// What one search reads and writes besides its spans.
struct BoxSearchFrame {
    const scene::Scene& scene;
    const FillScene& fill;
    const Camera& camera;
    const raster::RenderOptions& render;  // colorOnly false
    const raster::RenderTargets& targets;
    // Fu's search runs "from the polygons surrounding the hole towards the back": geometry
    // wholly nearer than the nearest of them (1/w above frontInvW, with a slack) is skipped.
    // 0: no bound (holes at the image border, where a pole entering the view lies in front of
    // everything around the hole it opens).
    float frontInvW = 0.0f;
};

// Draws into the pixels of `spans` (row order, one hole piece, every pixel holding ID 0) the
// nearest triangle there, as the full render does: every triangle whose box, corners and
// projection may reach the spans is scan-converted with the depth test, nearest boxes first, and
// once no pixel is left empty a box wholly behind the farthest pixel drawn is skipped with its
// subtree. Adds its counts to *stats. Preconditions: fill.boxCorners is filled (buildFillScene).
void searchBoxHierarchy(const BoxSearchFrame& frame, std::span<const raster::PixelSpan> spans,
                        FillStats* stats);

}  // namespace plx::stereo
