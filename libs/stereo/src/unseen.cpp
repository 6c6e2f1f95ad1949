// Geometry outside the first eye's view in front of reprojected pixels (unseen.h).

#include <plx/stereo/unseen.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <tuple>

#include <plx/stereo/stereo.h>

namespace plx::stereo {
namespace {

// The row of clipFromWorld that gives a world point's clip w.
Vec4 rowW(const Camera& camera) {
    const Mat4& m = camera.clipFromWorld();
    return {m[0][3], m[1][3], m[2][3], m[3][3]};
}

// Signed distance of p from a plane (n, d), scaled by |n|: >= 0 inside.
float distance(const Vec4& plane, const Vec3& p) {
    return plane.x * p.x + plane.y * p.y + plane.z * p.z + plane.w;
}

// The unseen wedge as planes (n, d), inside where dot(n, p) + d >= 0: the second eye's frustum
// (its four sides and the near plane, RectFrustum) and the first eye's side plane flipped.
struct Wedge {
    std::array<Vec4, scene::RectFrustum::kPlanes + 2> planes;

    bool mayCoverBox(const Aabb& box) const {
        for (const Vec4& p : planes) {
            Vec3 far(p.x >= 0.0f ? box.hi.x : box.lo.x, p.y >= 0.0f ? box.hi.y : box.lo.y,
                     p.z >= 0.0f ? box.hi.z : box.lo.z);
            if (distance(p, far) < 0.0f) return false;
        }
        return true;
    }
};

// With a < 0 the wedge lies beyond the first eye's right side (x >= width), with a > 0 beyond
// its left side (x <= 0). RectFrustum's planes of a one-column rectangle just outside the image
// give that side, moved outwards by its rounding margin, so the flipped plane keeps a little
// more than the wedge: the per-pixel test decides.
//
// A far plane too: a wedge point seen at a sample (centre 0.5 or more inside the image) comes
// from x1 at least 0.5 beyond the first eye's border, so its offset a / w + b is at least 0.5
// the wedge's way, which bounds w when b leaves room (w <= |a| / (0.5 + b) for a < 0; a plane
// 1/4 pixel looser here). Without that bound (b against it) the plane keeps everything.
Wedge wedgeOf(const Camera& first, const Camera& second, const DisparityLine& line) {
    const bool rightSide = line.perInvW < 0.0f;
    const int w = first.width(), h = first.height();
    Wedge wedge;
    const scene::RectFrustum secondView(second, {0, 0, w, h});
    std::copy(secondView.planes().begin(), secondView.planes().end(), wedge.planes.begin());
    // Plane 0 keeps x >= rect.x0, plane 1 keeps x <= rect.x1 (RectFrustum's order).
    const scene::RectFrustum beyond(
        first, rightSide ? scene::PixelRect{w, 0, w + 1, h} : scene::PixelRect{-1, 0, 0, h});
    wedge.planes[scene::RectFrustum::kPlanes] = rightSide ? beyond.planes()[0] : beyond.planes()[1];
    const float room = 0.25f + (rightSide ? line.offsetPx : -line.offsetPx);
    const float farW = room > 0.0f ? std::fabs(line.perInvW) / room : INFINITY;
    wedge.planes.back() = std::isfinite(farW) ? Vec4(0.0f, 0.0f, 0.0f, farW) - rowW(second)
                                              : Vec4(0.0f, 0.0f, 0.0f, 1.0f);
    return wedge;
}

// Sutherland-Hodgman: the part of a triangle inside every plane of the wedge, each plane adding
// a corner at most. Corners inside every plane (most triangles the walk reaches lie wholly in the
// wedge's planes but one) are taken as they are.
struct ClipPolygon {
    std::array<Vec3, 3 + std::tuple_size_v<decltype(Wedge::planes)>> corners;
    size_t size = 0;
    std::span<const Vec3> view() const { return {corners.data(), size}; }
};

ClipPolygon clipToWedge(const Wedge& wedge, const std::array<Vec3, 3>& triangle) {
    ClipPolygon poly;
    std::copy(triangle.begin(), triangle.end(), poly.corners.begin());
    poly.size = 3;
    ClipPolygon next;
    for (const Vec4& p : wedge.planes) {
        std::array<float, std::tuple_size_v<decltype(ClipPolygon::corners)>> d;
        size_t inside = 0;
        for (size_t i = 0; i < poly.size; ++i)
            inside += (d[i] = distance(p, poly.corners[i])) >= 0.0f;
        if (inside == poly.size) continue;
        if (inside == 0) return {};
        next.size = 0;
        for (size_t i = 0; i < poly.size; ++i) {
            const size_t j = i + 1 == poly.size ? 0 : i + 1;
            const Vec3 &a = poly.corners[i], &b = poly.corners[j];
            if (d[i] >= 0.0f) next.corners[next.size++] = a;
            if ((d[i] >= 0.0f) != (d[j] >= 0.0f))
                next.corners[next.size++] = a + (b - a) * (d[i] / (d[i] - d[j]));
        }
        poly = next;
    }
    return poly;
}

// A triangle or a box to draw or test: the pixel rectangle, inclusive, its part in the wedge can
// reach (empty when x0 > x1), and that part's nearest clip w.
struct Footprint {
    int32_t x0, x1, y0, y1;
    float nearW;
};

// The footprint of points at clip w > 0: their projection's rectangle, one pixel more on each
// side for rounding, within the image; empty for NaN.
Footprint footprintOf(const Camera& camera, std::span<const Vec3> points, float nearW) {
    float x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (const Vec3& p : points) {
        Vec2 px = camera.pixelFromClip(camera.clipFromWorld() * Vec4(p, 1.0f));
        x0 = std::min(x0, px.x), x1 = std::max(x1, px.x);
        y0 = std::min(y0, px.y), y1 = std::max(y1, px.y);
    }
    Footprint f{0, -1, 0, -1, nearW};
    if (!(x0 <= x1 && y0 <= y1)) return f;  // NaN
    const float w = float(camera.width() - 1), h = float(camera.height() - 1);
    f.x0 = int(std::clamp(std::floor(x0) - 1.0f, 0.0f, w));
    f.x1 = int(std::clamp(std::floor(x1) + 1.0f, 0.0f, w));
    f.y0 = int(std::clamp(std::floor(y0) - 1.0f, 0.0f, h));
    f.y1 = int(std::clamp(std::floor(y1) + 1.0f, 0.0f, h));
    return f;
}

// The footprint of a triangle's clipped part (every corner is on or behind the near plane).
Footprint partFootprint(const Camera& camera, const ClipPolygon& part) {
    float nearW = INFINITY;
    for (const Vec3& p : part.view())
        nearW = std::min(nearW, glm::dot(rowW(camera), Vec4(p, 1.0f)));
    return footprintOf(camera, part.view(), nearW);
}

// The columns a wedge sample of a point at clip w >= minW can fall on, one more on the inner
// side for rounding (empty when first > last). With a < 0 such a sample has X + 0.5 - (a v + b)
// >= width for a 1/w v <= 1/minW, so X >= width - 0.5 + a / minW + b; with a > 0, X <= a / minW
// + b - 0.5 (unseen.h).
std::pair<int, int> wedgeColumns(const DisparityLine& line, int width, float minW) {
    const float reach = line.perInvW / minW + line.offsetPx;
    if (line.perInvW < 0.0f) {
        const float first = std::floor(float(width) - 0.5f + reach) - 1.0f;
        return {int(std::clamp(first, 0.0f, float(width))), width - 1};
    }
    const float last = std::ceil(reach - 0.5f) + 1.0f;
    return {0, int(std::clamp(last, -1.0f, float(width - 1)))};
}

// The smallest clip w of a box's points (the row of clip w taken at the box's nearest corner).
float nearestW(const Vec4& w, const Aabb& box) {
    return w.x * (w.x >= 0.0f ? box.lo.x : box.hi.x) + w.y * (w.y >= 0.0f ? box.lo.y : box.hi.y) +
           w.z * (w.z >= 0.0f ? box.lo.z : box.hi.z) + w.w;
}

// The footprint of a box's part in the wedge, whose nearest clip w is nearW: the box's, within
// the wedge's columns at that depth. Empty where the box reaches in front of the near plane,
// whose projection is unbounded.
Footprint boxFootprint(const Camera& camera, const DisparityLine& line, const Aabb& box,
                       float nearW) {
    if (!(nearW >= camera.desc().nearPlane)) return {0, -1, 0, -1, nearW};
    std::array<Vec3, 8> corners;
    for (int c = 0; c < 8; ++c)
        corners[c] = {c & 1 ? box.hi.x : box.lo.x, c & 2 ? box.hi.y : box.lo.y,
                      c & 4 ? box.hi.z : box.lo.z};
    Footprint f = footprintOf(camera, corners, nearW);
    const auto [wedgeX0, wedgeX1] = wedgeColumns(line, camera.width(), nearW);
    f.x0 = std::max(f.x0, wedgeX0), f.x1 = std::min(f.x1, wedgeX1);
    return f;
}

// The band the triangles are drawn into: the columns a wedge sample can fall on from the
// nearest triangle drawn on (no later one reaches farther, as the walk goes nearest box first),
// packed (UnseenScratch::bandTargets), and on each row a run of columns cleared as triangles
// are drawn over it.
class Band {
public:
    Band(UnseenScratch* scratch, int width, int height) : mS(*scratch), mW(width), mH(height) {
        mS.rowX0.assign(size_t(height), width);
        mS.rowX1.assign(size_t(height), -1);
    }

    bool started() const { return mX0 <= mX1; }
    // Fixes the band's columns: those a wedge sample of a point at clip w >= minW can fall on.
    void start(const DisparityLine& line, float minW) {
        std::tie(mX0, mX1) = wedgeColumns(line, mW, minW);
        if (started()) mTargets = mS.bandTargets(mW, mH, mX0, mX1);
    }

    // Whether every pixel of f's rectangle, not empty, holds something nearer than f's nearest
    // point.
    bool hides(const Footprint& f) const {
        if (f.x0 > f.x1 || f.y0 > f.y1) return false;
        const float nearInvW = 1.0f / f.nearW;
        for (int y = f.y0; y <= f.y1; ++y) {
            if (f.x0 < mS.rowX0[y] || f.x1 > mS.rowX1[y]) return false;
            for (int x = f.x0; x <= f.x1; ++x)
                if (!(mTargets.depth.at(x, y) > nearInvW)) return false;
        }
        return true;
    }

    // Clamps f's columns to the band's; false when none are left.
    bool clampColumns(Footprint* f) const {
        f->x0 = std::max(f->x0, mX0), f->x1 = std::min(f->x1, mX1);
        return f->x0 <= f->x1;
    }

    // Clears the pixels of f's rectangle not cleared before (each row's run grows to hold it).
    void clear(const Footprint& f) {
        for (int y = f.y0; y <= f.y1; ++y) {
            int32_t &x0 = mS.rowX0[y], &x1 = mS.rowX1[y];
            if (x0 > x1) {
                clearColumns(y, f.x0, f.x1);
                x0 = f.x0, x1 = f.x1;
                continue;
            }
            if (f.x0 < x0) clearColumns(y, f.x0, x0 - 1), x0 = f.x0;
            if (f.x1 > x1) clearColumns(y, x1 + 1, f.x1), x1 = f.x1;
        }
    }

    const raster::RenderTargets& targets() const { return mTargets; }

private:
    void clearColumns(int y, int x0, int x1) {
        std::fill_n(&mTargets.depth.at(x0, y), x1 - x0 + 1, 0.0f);
        std::fill_n(&mTargets.id.at(x0, y), x1 - x0 + 1, 0u);
    }

    UnseenScratch& mS;
    int mW, mH;
    int mX0 = 0, mX1 = -1;
    raster::RenderTargets mTargets;
};

// Steps 1 to 3: the box hierarchy walked nearest box first (a heap on their nearest clip w),
// each leaf's triangles clipped to the wedge and those with a part left drawn over their
// rectangles, unless the band already holds something nearer throughout; a box whose own
// rectangle is so hidden is not opened. The parallel rig's wedge runs deep, past the walls
// that hide most of what it holds: the walk ends at them.
void drawWedge(const scene::Scene& scene, const FillScene& fill, const Camera& second,
               const DisparityLine& line, const Wedge& wedge, const raster::RenderOptions& options,
               Band* band, UnseenScratch* s, UnseenStats* stats) {
    const scene::BoxHierarchy& boxes = fill.boxes;
    if (boxes.nodeCount() == 0) return;
    const Vec4 clipW = rowW(second);
    const float nearPlane = second.desc().nearPlane;
    auto& heap = s->heap;
    const auto farther = [](const auto& a, const auto& b) { return a.first > b.first; };
    auto push = [&](uint32_t index) {
        const Aabb& box = boxes.node(index).box;
        ++stats->boxNodesTested;
        if (!wedge.mayCoverBox(box)) return;
        heap.emplace_back(nearestW(clipW, box), index);
        std::push_heap(heap.begin(), heap.end(), farther);
    };
    heap.clear();
    push(0);
    while (!heap.empty()) {
        std::pop_heap(heap.begin(), heap.end(), farther);
        const auto [boxNearW, index] = heap.back();
        heap.pop_back();
        const scene::BoxNode& node = boxes.node(index);
        if (band->started() && band->hides(boxFootprint(second, line, node.box, boxNearW)))
            continue;
        if (!node.isLeaf()) {
            push(index + 1);
            push(node.first);
            continue;
        }
        for (uint32_t e = node.first; e < node.first + node.count; ++e) {
            const ClipPolygon part = clipToWedge(wedge, fill.boxCorners.triangle(e));
            if (part.size == 0) continue;
            Footprint f = partFootprint(second, part);
            if (f.x0 > f.x1 || f.y0 > f.y1) continue;
            ++stats->trianglesReached;
            if (!band->started()) band->start(line, std::max(boxNearW, nearPlane));
            if (!band->clampColumns(&f) || band->hides(f)) continue;
            band->clear(f);
            s->rectSpans.clear();
            for (int y = f.y0; y <= f.y1; ++y) s->rectSpans.push_back({y, f.x0, f.x1});
            const std::array<Vec3, 3> corners = fill.boxCorners.triangle(e);
            raster::drawTriangleInSpans(scene, boxes.triangles()[e], corners, second, options,
                                        band->targets(), s->rectSpans);
            ++stats->trianglesDrawn;
        }
    }
}

template <class T>
ImageView<T> bandView(std::vector<T>* plane, int width, int height, int x0, int x1) {
    const ptrdiff_t stride = x1 - x0 + 1;
    plane->resize(size_t((height - 1) * stride + width));
    return {plane->data(), width, height, stride};
}

}  // namespace

raster::RenderTargets UnseenScratch::bandTargets(int width, int height, int x0, int x1) {
    return {bandView(&color, width, height, x0, x1),
            bandView(&depth, width, height, x0, x1),
            bandView(&id, width, height, x0, x1),
            {}};
}

UnseenStats drawUnseenOccluders(const scene::Scene& scene, const FillScene& fill,
                                const Camera& first, const Camera& secondCamera,
                                const DisparityLine& line, const raster::RenderOptions& render,
                                const raster::RenderTargets& second, ImageView<uint8_t> holeClass,
                                UnseenScratch* scratch) {
    UnseenStats stats;
    if (line.perInvW == 0.0f) return stats;
    const int w = secondCamera.width(), h = secondCamera.height();
    const bool rightSide = line.perInvW < 0.0f;
    raster::RenderOptions options = render;
    options.colorOnly = false;
    Band band(scratch, w, h);
    drawWedge(scene, fill, secondCamera, line, wedgeOf(first, secondCamera, line), options, &band,
              scratch, &stats);
    if (!band.started()) return stats;

    // Step 4: the samples whose nearest point lies in the wedge (unseen.h).
    const float width = float(w);
    const raster::RenderTargets& drawn = band.targets();
    for (int y = 0; y < h; ++y) {
        for (int x = scratch->rowX0[y]; x <= scratch->rowX1[y]; ++x) {
            const uint32_t id = drawn.id.at(x, y);
            if (id == 0) continue;
            const float invW = drawn.depth.at(x, y);
            const float x1 = float(x) + 0.5f - (line.perInvW * invW + line.offsetPx);
            if (rightSide ? !(x1 >= width) : !(x1 <= 0.0f)) continue;
            second.color.at(x, y) = drawn.color.at(x, y);
            if (second.depth.data) second.depth.at(x, y) = invW;
            if (second.id.data) second.id.at(x, y) = id;
            if (holeClass.data && holeClass.at(x, y) == uint8_t(PixelSource::kReprojected))
                holeClass.at(x, y) = uint8_t(PixelSource::kUnseen);
            ++stats.pixels;
        }
    }
    return stats;
}

}  // namespace plx::stereo
