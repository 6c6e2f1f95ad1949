// Disocclusion search over the box hierarchy with the depth test. See box_search.h and fill.h.

#include "box_search.h"

#include <algorithm>
#include <array>
#include <limits>

#include "polygon_spans.h"

namespace plx::stereo {

using raster::PixelSpan;

namespace {

// Relative slack on the depth comparison that skips hidden boxes: the rasterizer interpolates
// 1/w in float across the screen, a few ulps (~1e-6 relative) off the exact value a box bounds;
// 1/1024 keeps every skip a true one and costs only boxes almost touching the filled surface.
constexpr float kHiddenSlack = 1.0f / 1024.0f;
// Relative slack of FrontBound.
constexpr float kFrontSlack = 1.0f / 64.0f;

class BoxSearch {
public:
    BoxSearch(const BoxSearchFrame& frame, std::span<const PixelSpan> spans, FillStats* stats)
        : mFrame(frame),
          mSpans(spans),
          mStats(stats),
          mFrustum(frame.camera, rectOf(spans)),
          mNearPlane(frame.camera.desc().nearPlane),
          mFront(frame.camera, frame.frontInvW) {
        const Mat4& m = frame.camera.clipFromWorld();
        mRowW = Vec4(m[0][3], m[1][3], m[2][3], m[3][3]);
        for (const PixelSpan& s : spans) mOpen += s.x1 - s.x0 + 1;
    }

    // Nearest box first, so that the pieces fill early and the hidden test prunes the rest.
    void run() {
        const scene::BoxHierarchy& boxes = mFrame.fill.boxes;
        if (boxes.nodeCount() == 0) return;
        // Median splits bound the depth by 33 for 2^32 triangles; at most two entries per level.
        std::array<uint32_t, 80> stack;
        size_t top = 0;
        stack[top++] = 0;
        const Vec3 eye = mFrame.camera.eyePos();
        while (top > 0) {
            const uint32_t index = stack[--top];
            const scene::BoxNode& node = boxes.node(index);
            ++mStats->boxNodesTested;
            if (!mFrustum.mayCoverBox(node.box) || hidden(nearestW(node.box)) ||
                mFront.inFront(node.box))
                continue;
            if (node.isLeaf()) {
                for (uint32_t i = node.first; i < node.first + node.count; ++i) visitTriangle(i);
                continue;
            }
            uint32_t nearChild = index + 1, farChild = node.first;
            if (distance2(boxes.node(farChild).box, eye) <
                distance2(boxes.node(nearChild).box, eye))
                std::swap(nearChild, farChild);
            PLX_DCHECK(top + 2 <= stack.size());
            stack[top++] = farChild;
            stack[top++] = nearChild;
        }
    }

private:
    // Entry `entry` of the hierarchy's leaf order: pre-tests, then the depth-tested scan
    // conversion into the spans.
    void visitTriangle(uint32_t entry) {
        const std::span<const Vec3> corners(mFrame.fill.boxCorners.data() + 3 * size_t(entry), 3);
        ++mStats->polygonsTested;
        if (!mFrustum.mayCoverPoints(corners)) return;
        if (mFront.inFront(corners)) return;
        if (mOpen == 0) {
            float w = std::numeric_limits<float>::infinity();
            for (const Vec3& c : corners) w = std::min(w, clipW(c));
            if (hidden(w)) return;
        }
        if (!polygonMayCoverSpans(mFrame.camera, corners, mSpans)) return;
        ++mStats->polygonsDrawn;
        const uint32_t triangle = mFrame.fill.boxes.triangles()[entry];
        if (raster::drawTriangleInSpans(mFrame.scene, triangle, mFrame.camera, mFrame.render,
                                        mFrame.targets, mSpans) > 0)
            update();
    }

    // Recounts the empty pixels and the farthest 1/w drawn (the depth target holds 1/w).
    void update() {
        mOpen = 0;
        mFarthest = std::numeric_limits<float>::infinity();
        for (const PixelSpan& s : mSpans) {
            for (int x = s.x0; x <= s.x1; ++x) {
                if (mFrame.targets.id.at(x, s.y) == 0) ++mOpen;
                mFarthest = std::min(mFarthest, mFrame.targets.depth.at(x, s.y));
            }
        }
    }

    // Whether geometry whose smallest clip w is `w` lies wholly behind every pixel of a full
    // piece: its largest 1/w, widened by the slack, below the farthest 1/w drawn. Geometry
    // reaching nearer than the near plane is never hidden.
    bool hidden(float w) const {
        return mOpen == 0 && w > mNearPlane && (1.0f + kHiddenSlack) < mFarthest * w;
    }

    float clipW(const Vec3& p) const {
        return mRowW.x * p.x + mRowW.y * p.y + mRowW.z * p.z + mRowW.w;
    }
    // Smallest clip w over a box: the corner minimising the linear function.
    float nearestW(const Aabb& b) const {
        return mRowW.x * (mRowW.x >= 0.0f ? b.lo.x : b.hi.x) +
               mRowW.y * (mRowW.y >= 0.0f ? b.lo.y : b.hi.y) +
               mRowW.z * (mRowW.z >= 0.0f ? b.lo.z : b.hi.z) + mRowW.w;
    }
    static float distance2(const Aabb& b, const Vec3& eye) {
        const Vec3 d = b.center() - eye;
        return d.x * d.x + d.y * d.y + d.z * d.z;
    }
    static scene::PixelRect rectOf(std::span<const PixelSpan> spans) {
        scene::PixelRect r{std::numeric_limits<int>::max(), std::numeric_limits<int>::max(),
                           std::numeric_limits<int>::min(), std::numeric_limits<int>::min()};
        for (const PixelSpan& p : spans) {
            r.x0 = std::min(r.x0, p.x0);
            r.x1 = std::max(r.x1, p.x1 + 1);
            r.y0 = std::min(r.y0, p.y);
            r.y1 = std::max(r.y1, p.y + 1);
        }
        return r;
    }

    const BoxSearchFrame& mFrame;
    std::span<const PixelSpan> mSpans;
    FillStats* mStats;
    scene::RectFrustum mFrustum;
    float mNearPlane;
    Vec4 mRowW;
    FrontBound mFront;
    int64_t mOpen = 0;
    float mFarthest = 0.0f;
};

}  // namespace

FrontBound::FrontBound(const Camera& camera, float frontInvW) {
    if (!(frontInvW > 0.0f)) return;
    const Mat4& m = camera.clipFromWorld();
    mRowW = Vec4(m[0][3], m[1][3], m[2][3], m[3][3]);
    mFrontW = (1.0f - kFrontSlack) / frontInvW;
}

bool FrontBound::inFront(const Aabb& b) const {
    if (mFrontW == 0.0f) return false;
    // The box's farthest corner along the clip-w row.
    const float farthest = mRowW.x * (mRowW.x >= 0.0f ? b.hi.x : b.lo.x) +
                           mRowW.y * (mRowW.y >= 0.0f ? b.hi.y : b.lo.y) +
                           mRowW.z * (mRowW.z >= 0.0f ? b.hi.z : b.lo.z) + mRowW.w;
    return farthest < mFrontW;
}

bool FrontBound::inFront(std::span<const Vec3> points) const {
    if (mFrontW == 0.0f) return false;
    for (const Vec3& p : points)
        if (clipW(p) >= mFrontW) return false;
    return true;
}

void searchBoxHierarchy(const BoxSearchFrame& frame, std::span<const PixelSpan> spans,
                        FillStats* stats) {
    if (spans.empty()) return;
    BoxSearch(frame, spans, stats).run();
}

}  // namespace plx::stereo
