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

// The pixel rectangle of a clipped part's projection (every corner is on or behind the near
// plane, so w > 0), one pixel more on each side for rounding; empty for a degenerate clip.
UnseenScratch::Kept rectOf(const Camera& camera, const ClipPolygon& part, uint32_t entry) {
    float x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (const Vec3& p : part.view()) {
        Vec2 px = camera.pixelFromClip(camera.clipFromWorld() * Vec4(p, 1.0f));
        x0 = std::min(x0, px.x), x1 = std::max(x1, px.x);
        y0 = std::min(y0, px.y), y1 = std::max(y1, px.y);
    }
    UnseenScratch::Kept k{entry, 0, -1, 0, -1, INFINITY};
    for (const Vec3& p : part.view())
        k.nearW = std::min(k.nearW, glm::dot(rowW(camera), Vec4(p, 1.0f)));
    if (!(x0 <= x1 && y0 <= y1)) return k;  // NaN
    const float w = float(camera.width() - 1), h = float(camera.height() - 1);
    k.x0 = int(std::clamp(std::floor(x0) - 1.0f, 0.0f, w));
    k.x1 = int(std::clamp(std::floor(x1) + 1.0f, 0.0f, w));
    k.y0 = int(std::clamp(std::floor(y0) - 1.0f, 0.0f, h));
    k.y1 = int(std::clamp(std::floor(y1) + 1.0f, 0.0f, h));
    return k;
}

// Steps 1 and 2: the triangles whose clipped part reaches the wedge with their rectangles, and
// the band's rows (their union).
void collectTriangles(const FillScene& fill, const Camera& second, const Wedge& wedge,
                      UnseenScratch* s) {
    const scene::BoxHierarchy& boxes = fill.boxes;
    if (boxes.nodeCount() == 0) return;
    // One pending second child per level, and the node being split.
    std::array<uint32_t, scene::BoxHierarchy::kMaxDepth + 1> stack;
    size_t top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const uint32_t index = stack[--top];
        const scene::BoxNode& node = boxes.node(index);
        if (!wedge.mayCoverBox(node.box)) continue;
        if (!node.isLeaf()) {
            stack[top++] = node.first;  // second child; the first follows its parent
            stack[top++] = index + 1;
            continue;
        }
        for (uint32_t e = node.first; e < node.first + node.count; ++e) {
            const ClipPolygon part = clipToWedge(wedge, fill.boxCorners.triangle(e));
            if (part.size == 0) continue;
            UnseenScratch::Kept k = rectOf(second, part, e);
            if (k.x0 > k.x1 || k.y0 > k.y1) continue;
            s->kept.push_back(k);
            for (int y = k.y0; y <= k.y1; ++y) {
                s->rowX0[y] = std::min(s->rowX0[y], k.x0);
                s->rowX1[y] = std::max(s->rowX1[y], k.x1);
            }
        }
    }
}

// Whether every pixel of k's rectangle holds something nearer than k's nearest point.
bool hiddenInBand(const raster::RenderTargets& band, const UnseenScratch::Kept& k) {
    const float nearInvW = 1.0f / k.nearW;
    for (int y = k.y0; y <= k.y1; ++y)
        for (int x = k.x0; x <= k.x1; ++x)
            if (!(band.depth.at(x, y) > nearInvW)) return false;
    return true;
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
    UnseenScratch& s = *scratch;
    s.kept.clear();
    s.rowX0.assign(size_t(h), w);
    s.rowX1.assign(size_t(h), -1);
    collectTriangles(fill, secondCamera, wedgeOf(first, secondCamera, line), &s);
    if (s.kept.empty()) return stats;

    // Step 3: the kept triangles, whole, over the band with the depth test.
    s.spans.clear();
    int bandX0 = w, bandX1 = -1;
    for (int y = 0; y < h; ++y) {
        if (s.rowX0[y] > s.rowX1[y]) continue;
        s.spans.push_back({y, s.rowX0[y], s.rowX1[y]});
        bandX0 = std::min(bandX0, s.rowX0[y]);
        bandX1 = std::max(bandX1, s.rowX1[y]);
    }
    const raster::RenderTargets band = s.bandTargets(w, h, bandX0, bandX1);
    for (const raster::PixelSpan& span : s.spans) {
        std::fill_n(&band.depth.at(span.x0, span.y), span.x1 - span.x0 + 1, 0.0f);
        std::fill_n(&band.id.at(span.x0, span.y), span.x1 - span.x0 + 1, 0u);
    }
    raster::RenderOptions options = render;
    options.colorOnly = false;
    // Nearest first, each over its own rectangle: elsewhere its points lie in the first eye's
    // view, behind any wedge point on their rays, and step 4 keeps wedge points only. One whose
    // rectangle is drawn nearer than its nearest point throughout cannot win a pixel: skipped
    // (the parallel rig's wedge runs deep, past walls that hide most of what it holds).
    std::sort(s.kept.begin(), s.kept.end(),
              [](const auto& a, const auto& b) { return a.nearW < b.nearW; });
    for (const UnseenScratch::Kept& k : s.kept) {
        if (hiddenInBand(band, k)) continue;
        s.rectSpans.clear();
        for (int y = k.y0; y <= k.y1; ++y) s.rectSpans.push_back({y, k.x0, k.x1});
        const std::array<Vec3, 3> corners = fill.boxCorners.triangle(k.entry);
        raster::drawTriangleInSpans(scene, fill.boxes.triangles()[k.entry], corners, secondCamera,
                                    options, band, s.rectSpans);
        ++stats.trianglesDrawn;
    }

    // Step 4: the samples whose nearest point lies in the wedge (unseen.h).
    const float width = float(w);
    for (const raster::PixelSpan& span : s.spans) {
        for (int x = span.x0; x <= span.x1; ++x) {
            const uint32_t id = band.id.at(x, span.y);
            if (id == 0) continue;
            const float invW = band.depth.at(x, span.y);
            const float x1 = float(x) + 0.5f - (line.perInvW * invW + line.offsetPx);
            if (rightSide ? !(x1 >= width) : !(x1 <= 0.0f)) continue;
            second.color.at(x, span.y) = band.color.at(x, span.y);
            if (second.depth.data) second.depth.at(x, span.y) = invW;
            if (second.id.data) second.id.at(x, span.y) = id;
            if (holeClass.data && holeClass.at(x, span.y) == uint8_t(PixelSource::kReprojected))
                holeClass.at(x, span.y) = uint8_t(PixelSource::kUnseen);
            ++stats.pixels;
        }
    }
    return stats;
}

}  // namespace plx::stereo
