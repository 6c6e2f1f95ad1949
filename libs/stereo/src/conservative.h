#pragma once
// The conservative visible set (beyond the paper). Heo, Jung and Wohn accept that polygons newly
// visible to the second eye are missed. Two kinds exist:
//  1. polygons outside the first eye's frustum that the second eye sees near the image border;
//  2. polygons hidden in the first eye behind a foreground edge and revealed to the second eye.
// Both lie within one disparity of what the first eye sees. So the first eye is rendered over a
// guard band of that many extra columns on each side (kind 1), with the raster's optional second
// depth layer (the nearest hidden surface per pixel); the second-layer IDs within that many
// columns of a depth discontinuity join the set (kind 2).

#include <plx/stereo/stereo.h>

namespace plx::stereo {

struct ConservativeScratch {
    raster::FrameBuffers wide;     // first eye with the guard band
    Image<float> depth2;
    Image<uint32_t> id2;
    Image<uint8_t> edgeBand;       // 1 where a second-layer ID joins the set
    int bandPx = 0;
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
void addConservativePolygons(ConservativeScratch& scratch, VisibleSetCollector* collector);

}  // namespace plx::stereo
