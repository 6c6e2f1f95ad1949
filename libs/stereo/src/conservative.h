#pragma once
// The conservative visible set (beyond the paper). Heo, Jung and Wohn accept that polygons newly
// visible to the second eye are missed. Three kinds exist:
//  1. polygons outside the first eye's frustum that the second eye sees near the image border;
//  2. polygons hidden in the first eye behind a foreground edge and revealed to the second eye;
//  3. polygons smaller than a pixel that the first eye's sample centres fall between while the
//     second eye's (shifted by a fraction of a pixel) hit them. Measured on office:280, these
//     are most of the missed polygons: distant furniture covering one or two pixels.
// Kinds 1 and 2 lie within one disparity of what the first eye sees. So the first eye is
// rendered over a guard band of that many extra columns on each side (kind 1), with the raster's
// optional second depth layer (the nearest hidden surface per pixel); at each depth
// discontinuity the second-layer IDs over the width the edge's disparity change can reveal join
// the set (kind 2). For kind 3 the rasterizer reports the triangles that covered no sample yet
// lie in front of the depth around them (raster::VisibilityOutputs::unsampledVisible).

#include <plx/stereo/stereo.h>

namespace plx::stereo {

struct ConservativeScratch {
    raster::FrameBuffers wide;     // first eye with the guard band
    Image<float> depth2;
    Image<uint32_t> id2;
    Image<uint8_t> edgeBand;       // 1 where a second-layer ID joins the set
    std::vector<uint32_t> unsampled;  // sub-pixel triangles in front of the depth around them
    int bandPx = 0;
    float disparityScale = 0.0f;   // e * f: pixels of disparity per unit of 1/w
    float nearestDepth = 0.0f;     // nearest visible depth of the last frame (0: none yet)
};

// Depth below which disparities are not budgeted for on the first frame (metres). Nearer than
// this, parallax exceeds comfortable fusion for typical displays anyway; later frames use the
// previous frame's nearest depth.
constexpr float kDefaultNearestDepth = 0.5f;

// Renders the first eye over the guard band with two depth layers and crops the image into
// `first`. Returns the band width in pixels.
int renderConservativeFirstEye(raster::Renderer& renderer, const scene::Scene& scene,
                               const StereoRig& rig, const StereoOptions& options,
                               ConservativeScratch* scratch, raster::FrameBuffers* first);

// Adds the guard band's IDs and the second-layer IDs along depth discontinuities.
void addConservativePolygons(ConservativeScratch& scratch,
                             raster::VisibleSetCollector* collector);

}  // namespace plx::stereo
