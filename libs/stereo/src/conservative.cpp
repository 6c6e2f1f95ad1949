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

// Marks pixels within `band` columns of a depth discontinuity: neighbouring 1/w values differing
// by more than 10% of the nearer one (or drawn next to empty). Two sweeps per row, O(pixels).
void markEdgeBand(const Image<float>& depth, int band, Image<uint8_t>* mask) {
    const int w = depth.width(), h = depth.height();
    mask->resize(w, h);
    auto isEdge = [&](const float* row, int x) {
        float a = row[x], b = row[x + 1];
        return std::fabs(a - b) > 0.1f * std::max(a, b);
    };
    std::vector<uint8_t> edge(size_t(std::max(w, 1)), 0);
    for (int y = 0; y < h; ++y) {
        const float* row = depth.row(y);
        const float* up = y > 0 ? depth.row(y - 1) : nullptr;
        for (int x = 0; x < w; ++x) {
            bool e = x + 1 < w && isEdge(row, x);
            // Vertical neighbours matter too: a tilted edge shifts sideways between the eyes.
            if (up && std::fabs(row[x] - up[x]) > 0.1f * std::max(row[x], up[x])) e = true;
            edge[size_t(x)] = e;
        }
        uint8_t* out = mask->row(y);
        int last = -band - 1;
        for (int x = 0; x < w; ++x) {
            if (edge[size_t(x)]) last = x;
            out[x] = x - last <= band;
        }
        last = w + band + 1;
        for (int x = w - 1; x >= 0; --x) {
            if (edge[size_t(x)]) last = x;
            out[x] = out[x] || last - x <= band;
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
    targets.depth2 = s->depth2.view();
    targets.id2 = s->id2.view();
    renderer.render(scene, wide, options.render, targets);
    cropColumns(s->wide.color, band, &first->color);
    cropColumns(s->wide.depth, band, &first->depth);
    cropColumns(s->wide.id, band, &first->id);
    s->bandPx = band;
    float maxInvW = 0.0f;
    for (size_t i = 0; i < s->wide.depth.pixelCount(); ++i)
        maxInvW = std::max(maxInvW, s->wide.depth.data()[i]);
    s->nearestDepth = maxInvW > 0.0f ? 1.0f / maxInvW : 0.0f;
    return band;
}

void addConservativePolygons(ConservativeScratch& s, VisibleSetCollector* collector) {
    collector->add(s.wide.id);  // the guard band's polygons (the middle is already in)
    markEdgeBand(s.wide.depth, std::max(s.bandPx, 1), &s.edgeBand);
    collector->addMasked(s.id2, s.edgeBand);
}

}  // namespace plx::stereo
