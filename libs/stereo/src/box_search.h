#pragma once
// The disocclusion search of FillSearch::kBoxHierarchy (fill.h): the box hierarchy walked
// nearest box first with the depth test deciding visibility, in place of the BSP order.

#include <span>

#include <plx/raster/raster.h>
#include <plx/raster/span_fill.h>
#include <plx/stereo/fill.h>

namespace plx::stereo {

// Fu section 3: "polygons visible through the hole lie certainly behind the polygons surrounding
// the hole". Geometry whose farthest clip w is below the nearest surrounding pixel's w, less a
// slack (the pixels' 1/w is sampled at their centres, a fraction of a pixel from the hole, on
// surfaces that may slope towards the eye), lies wholly in front of them and is skipped.
class FrontBound {
public:
    // frontInvW: the largest 1/w beside the hole; 0 for no bound.
    FrontBound(const Camera& camera, float frontInvW);
    bool inFront(const Aabb& box) const;
    bool inFront(std::span<const Vec3> points) const;
    // The clip w below which geometry is in front (0: no bound), and the clip-w row it applies to.
    float frontW() const { return mFrontW; }

private:
    float clipW(const Vec3& p) const {
        return mRowW.x * p.x + mRowW.y * p.y + mRowW.z * p.z + mRowW.w;
    }
    Vec4 mRowW{0.0f};
    float mFrontW = 0.0f;  // 0: nothing is in front
};

// What one search reads and writes besides its spans.
struct BoxSearchFrame {
    const scene::Scene& scene;
    const FillScene& fill;
    const Camera& camera;
    const raster::RenderOptions& render;  // colorOnly false
    const raster::RenderTargets& targets;
    // FrontBound's 1/w: 0 for holes at the image border, where a pole entering the view lies in
    // front of everything around the hole it opens.
    float frontInvW = 0.0f;
};

// FillScene::wideBoxes of `boxes`: each inner node's grandchildren in one node, depth first.
std::vector<WideBoxNode> collapseFourWide(const scene::BoxHierarchy& boxes);

// Draws into the pixels of `spans` (row order, one hole piece, every pixel holding ID 0) the
// nearest triangle there, as the full render does: every triangle whose box, corners and
// projection may reach the spans is scan-converted with the depth test, nearest boxes first, and
// once no pixel is left empty a box wholly behind the farthest pixel drawn is skipped with its
// subtree. The walk goes over fill.wideBoxes, four boxes tested at a time. Beyond the paper, spans
// of at most kFillRayPixels pixels are walked along the rays through their samples: a box is
// entered where a ray widened by 1/16 pixel at the box's depth passes through it (tighter than
// the frustum's plane tests, which pass boxes beside a thin frustum), and the hidden test takes
// the nearest point where a ray enters it rather than its nearest corner; larger spans test boxes
// against the bundle of their rectangle's rays too, and the hidden test takes the larger of the
// box's nearest corner and the bundle's entry. Adds its counts to *stats (boxNodesTested counts
// boxes, rayPieces the walks along rays). Preconditions: fill.boxCorners and fill.wideBoxes are
// filled (buildFillScene).
void searchBoxHierarchy(const BoxSearchFrame& frame, std::span<const raster::PixelSpan> spans,
                        FillStats* stats);

}  // namespace plx::stereo
