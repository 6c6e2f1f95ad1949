#include <algorithm>
#include <cmath>

#include "conservative.h"

namespace plx::stereo {
namespace {

// Largest horizontal disparity (pixels) between the eyes for content at depths >= nearestDepth.
int disparityBudgetPx(const StereoRig& rig, float nearestDepth) {
    float nearDisparity = std::fabs(rig.disparityPx(nearestDepth));
    float farDisparity = std::fabs(rig.disparityPx(std::numeric_limits<float>::infinity()));
    return int(std::ceil(std::max(nearDisparity, farDisparity))) + 1;
}

// Marks where the second eye can see past a first-eye depth edge. Between horizontal neighbours
// with 1/w values a and b, the background is revealed over e * f * |a - b| pixels (the change of
// disparity across the edge, eq. 1), on either side depending on which eye comes second; both
// sides are marked. Two sweeps per row carry the remaining width, so the cost is O(pixels).
void markEdgeBand(const Image<float>& depth, float disparityScale, int maxBand,
                  Image<uint8_t>* mask) {
    const int w = depth.width(), h = depth.height();
    mask->resize(w, h);
    std::vector<int> reveal(size_t(std::max(w, 1)), 0);  // width revealed at the edge x|x+1
    for (int y = 0; y < h; ++y) {
        const float* row = depth.row(y);
        for (int x = 0; x + 1 < w; ++x) {
            float a = row[x], b = row[x + 1];
            float width = disparityScale * std::fabs(a - b);
            reveal[size_t(x)] = std::fabs(a - b) > 0.02f * std::max(a, b)
                                    ? std::min(int(std::ceil(width)) + 1, maxBand)
                                    : 0;
        }
        uint8_t* out = mask->row(y);
        int reach = 0;
        for (int x = 0; x < w; ++x) {
            out[x] = reach > 0;
            reach = std::max(reach - 1, x + 1 < w ? reveal[size_t(x)] : 0);
            out[x] |= reach > 0 && x + 1 < w && reveal[size_t(x)] > 0;
        }
        reach = 0;
        for (int x = w - 1; x >= 0; --x) {
            if (x + 1 < w) reach = std::max(reach, reveal[size_t(x)] + 1);
            out[x] |= reach > 0;
            reach = std::max(reach - 1, 0);
        }
    }
}

template <class T>
void cropColumns(const Image<T>& wide, int offset, Image<T>* out) {
    for (int y = 0; y < out->height(); ++y)
        std::copy_n(wide.row(y) + offset, out->width(), out->row(y));
}

}  // namespace

int renderConservativeFirstEye(raster::Renderer& renderer, const scene::Scene& scene,
                               const StereoRig& rig, const StereoOptions& options,
                               ConservativeScratch* s, raster::FrameBuffers* first) {
    const Camera& cam = rig.first();
    float nearest = s->nearestDepth > 0.0f ? s->nearestDepth : kDefaultNearestDepth;
    int band = std::min(disparityBudgetPx(rig, nearest), cam.width() / 2);
    // The same camera with `band` more columns on each side: the vertical field of view and the
    // principal point are unchanged, so the middle columns are the first eye's image.
    CameraDesc d = cam.desc();
    d.width = std::min(cam.width() + 2 * band, Camera::kMaxImageSide);
    band = (d.width - cam.width()) / 2;
    d.width = cam.width() + 2 * band;
    Camera wide = *Camera::create(d);
    if (s->wide.id.width() != d.width || s->wide.id.height() != d.height) {
        s->wide.resize(d.width, d.height);
        s->depth2.resize(d.width, d.height);
        s->id2.resize(d.width, d.height);
    }
    raster::RenderTargets targets = s->wide.targets();
    targets.visibility.depth2 = s->depth2.view();
    targets.visibility.id2 = s->id2.view();
    s->unsampled.clear();
    targets.visibility.unsampledVisible = &s->unsampled;
    renderer.render(scene, wide, options.render, targets);
    cropColumns(s->wide.color, band, &first->color);
    cropColumns(s->wide.depth, band, &first->depth);
    cropColumns(s->wide.id, band, &first->id);
    s->bandPx = band;
    s->disparityScale = rig.desc().separation * rig.projectionDistancePx();
    float maxInvW = 0.0f;
    for (size_t i = 0; i < s->wide.depth.pixelCount(); ++i)
        maxInvW = std::max(maxInvW, s->wide.depth.data()[i]);
    s->nearestDepth = maxInvW > 0.0f ? 1.0f / maxInvW : 0.0f;
    return band;
}

void addConservativePolygons(ConservativeScratch& s, raster::VisibleSetCollector* collector) {
    collector->add(s.wide.id);  // the guard band's polygons (the middle is already in)
    markEdgeBand(s.wide.depth, s.disparityScale, std::max(s.bandPx, 1), &s.edgeBand);
    collector->addMasked(s.id2, s.edgeBand);
    collector->addTriangles(s.unsampled);
}

}  // namespace plx::stereo
