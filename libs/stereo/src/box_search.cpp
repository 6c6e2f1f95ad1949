// Disocclusion search over the box hierarchy with the depth test. See box_search.h and fill.h.

#include "box_search.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
#include <xmmintrin.h>
#endif

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
// How far from a pixel's sample, in pixels, a triangle whose scan conversion covers it may lie:
// the rasterizer snaps corners to 1/256 pixel, moving each point of the triangle by at most
// sqrt 2 / 512 = 1/362 pixel; 1/16 leaves the float rounding of the tests a wide margin.
constexpr float kRayMarginPx = 1.0f / 16.0f;

// The direction of the ray from the eye through pixel point (x, y) (pixel centres at +0.5) that
// advances clip w by 1 per unit, so that a ray's parameter is clip w; not finite when the camera
// gives no such direction.
Vec3 directionThrough(const Camera& camera, float x, float y) {
    const Mat4& m = camera.clipFromWorld();
    auto row = [&m](int i) { return Vec4(m[0][i], m[1][i], m[2][i], m[3][i]); };
    const Vec4 rowW = row(3);
    // The planes through the eye and the point's column and row (RectFrustum's sides).
    const float ax = 2.0f * x / float(camera.width()) - 1.0f;
    const float by = 1.0f - 2.0f * y / float(camera.height());
    const Vec4 column = row(0) - ax * rowW, line = row(1) - by * rowW;
    const Vec3 dir = cross(Vec3(column), Vec3(line));
    return dir / dot(Vec3(rowW), dir);
}

// The rays through the samples of a piece of at most kFillRayPixels pixels (box_search.h).
struct SampleRays {
    static constexpr int kMax = kFillRayPixels;
    // Per ray and axis, 1 / the direction that advances clip w by 1 per unit.
    std::array<Vec3, kMax> invDir;
    int count = 0;
    float widenPerW = 0.0f;  // kRayMarginPx pixels in world units, times sqrt 2, per unit of w

    // False when the spans hold more than kMax pixels or a ray has no usable direction.
    static bool make(const Camera& camera, std::span<const PixelSpan> spans, SampleRays* out) {
        int pixels = 0;
        for (const PixelSpan& p : spans) pixels += p.x1 - p.x0 + 1;
        if (pixels > kMax) return false;
        out->count = 0;
        for (const PixelSpan& p : spans)
            for (int x = p.x0; x <= p.x1; ++x)
                if (!addRay(camera, x, p.y, out)) return false;
        // One pixel spans 2 w / (W m00) across and 2 w / (H m11) down in view space (w is minus
        // the view z for Camera's glm::perspective); a square of half-side r lies within
        // r sqrt 2 of its centre, whatever the axes.
        const Mat4& m = camera.clipFromView();
        const float pixel = std::max(2.0f / (float(camera.width()) * std::fabs(m[0][0])),
                                     2.0f / (float(camera.height()) * std::fabs(m[1][1])));
        out->widenPerW = kRayMarginPx * std::sqrt(2.0f) * pixel;
        return out->count > 0 && std::isfinite(out->widenPerW);
    }

private:
    static bool addRay(const Camera& camera, int x, int y, SampleRays* out) {
        const Vec3 dir = directionThrough(camera, float(x) + 0.5f, float(y) + 0.5f);
        if (!std::isfinite(dir.x) || !std::isfinite(dir.y) || !std::isfinite(dir.z)) return false;
        // A zero component stands in as a tiny one, so that the slab test forms no 0 * inf.
        auto inverse = [](float d) {
            constexpr float kTiny = std::numeric_limits<float>::min();
            return 1.0f / (std::fabs(d) >= kTiny ? d : std::copysign(kTiny, d));
        };
        const Vec3 inv(inverse(dir.x), inverse(dir.y), inverse(dir.z));
        if (!std::isfinite(inv.x) || !std::isfinite(inv.y) || !std::isfinite(inv.z)) return false;
        out->invDir[size_t(out->count++)] = inv;
        return true;
    }
};

// Beyond the paper: the rays through a larger piece's rectangle as one bundle, bounded per axis
// by the rays through its corners (interval arithmetic; a direction normalised to advance clip w
// by 1 is affine in the pixel point, so each component lies between its values at the corners).
// A box is entered only where some direction of the bounds reaches it on every axis, at a clip w
// no smaller than the least of its slabs' bounds: a test the plane tests do not make along the
// depth, and a lower bound on the box's depth inside the rectangle, often far beyond its nearest
// corner, for the hidden test. The corners lie half a pixel beyond the outer samples, which
// covers the rasterizer's snapping (1/362 pixel).
struct RayBundle {
    // Per axis, 1 / the smallest and 1 / the largest direction component; an axis on which the
    // components change sign, or are not finite, gives no bound (bounded false).
    std::array<float, 3> invLow{}, invHigh{};
    std::array<bool, 3> bounded{};

    static RayBundle of(const Camera& camera, const scene::PixelRect& rect) {
        Vec3 lo(std::numeric_limits<float>::infinity()), hi(-lo);
        for (int x : {rect.x0, rect.x1})
            for (int y : {rect.y0, rect.y1}) {
                const Vec3 d = directionThrough(camera, float(x), float(y));
                lo = min(lo, d);
                hi = max(hi, d);
            }
        RayBundle b;
        for (int a = 0; a < 3; ++a) {
            b.bounded[size_t(a)] =
                std::isfinite(lo[a]) && std::isfinite(hi[a]) && (lo[a] > 0.0f || hi[a] < 0.0f);
            b.invLow[size_t(a)] = 1.0f / lo[a];
            b.invHigh[size_t(a)] = 1.0f / hi[a];
        }
        return b;
    }
};

class BoxSearch {
public:
    BoxSearch(const BoxSearchFrame& frame, std::span<const PixelSpan> spans, FillStats* stats)
        : mFrame(frame),
          mSpans(spans),
          mStats(stats),
          mRect(rectOf(spans)),
          mFrustum(frame.camera, mRect),
          mNearPlane(frame.camera.desc().nearPlane),
          mFront(frame.camera, frame.frontInvW) {
        const Mat4& m = frame.camera.clipFromWorld();
        mRowW = Vec4(m[0][3], m[1][3], m[2][3], m[3][3]);
        // Geometry the front bound passes reaches beyond it, so beyond a near plane in front of
        // it: the near plane's test then rejects nothing more (up to rounding, which can only
        // let a box through that the rasterizer's near clipping empties).
        mPlaneCount = mFront.frontW() > mNearPlane ? scene::RectFrustum::kSidePlanes
                                                   : scene::RectFrustum::kPlanes;
        mRayMode = SampleRays::make(frame.camera, spans, &mRays);
        mStats->rayPieces += mRayMode;
        if (!mRayMode) mBundle = RayBundle::of(frame.camera, mRect);
#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
        for (size_t i = 0; i < mPlaneCount; ++i)
            mLanePlanes[i] = LanePlane(mFrustum.planes()[i], true);
        mFrontPlane = LanePlane(mRowW, true);
        mNearestW = LanePlane(mRowW, false);
#endif
    }

    // Nearest box first, so that the pieces fill early and the hidden test prunes the rest.
    void run() {
        const std::vector<WideBoxNode>& nodes = mFrame.fill.wideBoxes;
        if (nodes.empty()) return;
        // A binary depth of at most BoxHierarchy::kMaxDepth makes at most kMaxDepth / 2 wide
        // levels, each leaving at most three lanes on the stack, then four.
        std::array<Entry, 3 * (scene::BoxHierarchy::kMaxDepth / 2) + 4> stack;
        size_t top = 0;
        top = pushLanes(nodes[0], stack.data(), top);
        while (top > 0) {
            const Entry entry = stack[--top];
            // Re-tested: the piece may have filled since the entry was pushed.
            if (hidden(entry.nearW)) continue;
            if (entry.count == 0) {
                PLX_DCHECK(top + 4 <= stack.size());
                top = pushLanes(nodes[entry.first], stack.data(), top);
                continue;
            }
            visitLeaf(entry.first, entry.count);
        }
    }

private:
    // A lane waiting on the stack: an inner lane's WideBoxNode (count 0) or a leaf's triangles,
    // with its box's smallest clip w for the hidden test.
    struct Entry {
        uint32_t first;
        uint32_t count;
        float nearW;
    };

#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
    // A plane over the four lanes of a WideBoxNode: its coefficients broadcast, and per axis the
    // lane bound that is the box's far corner (the larger product: the upper bound where the
    // coefficient is not negative, as RectFrustum::mayCoverBox and FrontBound pick it) or its
    // near corner (nearestW).
    struct LanePlane {
        using Bound = std::array<float, 4> WideBoxNode::*;
        __m128 x, y, z, w;
        Bound cornerX, cornerY, cornerZ;

        LanePlane() = default;
        LanePlane(const Vec4& p, bool farCorner)
            : x(_mm_set1_ps(p.x)),
              y(_mm_set1_ps(p.y)),
              z(_mm_set1_ps(p.z)),
              w(_mm_set1_ps(p.w)),
              cornerX((p.x >= 0.0f) == farCorner ? &WideBoxNode::hiX : &WideBoxNode::loX),
              cornerY((p.y >= 0.0f) == farCorner ? &WideBoxNode::hiY : &WideBoxNode::loY),
              cornerZ((p.z >= 0.0f) == farCorner ? &WideBoxNode::hiZ : &WideBoxNode::loZ) {}

        // ((x + y) + z) + w at each lane's corner.
        __m128 atCorners(const WideBoxNode& n) const {
            const __m128 px = _mm_mul_ps(x, _mm_loadu_ps((n.*cornerX).data()));
            const __m128 py = _mm_mul_ps(y, _mm_loadu_ps((n.*cornerY).data()));
            const __m128 pz = _mm_mul_ps(z, _mm_loadu_ps((n.*cornerZ).data()));
            return _mm_add_ps(_mm_add_ps(_mm_add_ps(px, py), pz), w);
        }
        // ((x + y) + z) + w at four points.
        __m128 at(__m128 px, __m128 py, __m128 pz) const {
            const __m128 xy = _mm_add_ps(_mm_mul_ps(x, px), _mm_mul_ps(y, py));
            return _mm_add_ps(_mm_add_ps(xy, _mm_mul_ps(z, pz)), w);
        }
    };
#endif

    // One node's lane boxes against the frustum's planes (or the samples' rays) and the front
    // bound, each box's smallest clip w (or the rays' nearest entry) for the hidden test, and the
    // squared distance from the eye to each box's centre (or that entry again) that orders them,
    // with the scalar expressions' operations in their order (RectFrustum::mayCoverBox,
    // FrontBound, nearestW, Aabb::center, rayEntry), so both paths pass and order the same boxes.
    struct LaneTest {
        uint32_t pass = 0;  // bit per lane
        std::array<float, 4> nearW{};
        std::array<float, 4> order{};  // the smallest first
    };
    LaneTest testLanes(const WideBoxNode& n) const {
        LaneTest out;
#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
        if (mRayMode) return testLanesOnRay(n);
        const __m128 zero = _mm_setzero_ps();
        __m128 pass = _mm_castsi128_ps(_mm_set1_epi32(-1));
        for (size_t i = 0; i < mPlaneCount; ++i)  // rejected only below 0 (as the scalar test)
            pass = _mm_and_ps(pass, _mm_cmpnlt_ps(mLanePlanes[i].atCorners(n), zero));
        if (mFront.frontW() != 0.0f)
            pass = _mm_and_ps(
                pass, _mm_cmpnlt_ps(mFrontPlane.atCorners(n), _mm_set1_ps(mFront.frontW())));
        const Vec3 eye = mFrame.camera.eyePos();
        // The bundle's slabs (bundleSlabs).
        __m128 entry = _mm_set1_ps(mNearPlane);
        __m128 exit = _mm_set1_ps(std::numeric_limits<float>::infinity());
        const std::array<const std::array<float, 4>*, 3> boxLo{&n.loX, &n.loY, &n.loZ},
            boxHi{&n.hiX, &n.hiY, &n.hiZ};
        for (size_t a = 0; a < 3; ++a) {
            if (!mBundle.bounded[a]) continue;
            const __m128 e = _mm_set1_ps(eye[int(a)]);
            const __m128 l = _mm_sub_ps(_mm_loadu_ps(boxLo[a]->data()), e);
            const __m128 h = _mm_sub_ps(_mm_loadu_ps(boxHi[a]->data()), e);
            const __m128 invLow = _mm_set1_ps(mBundle.invLow[a]);
            const __m128 invHigh = _mm_set1_ps(mBundle.invHigh[a]);
            const __m128 l0 = _mm_mul_ps(l, invLow), l1 = _mm_mul_ps(l, invHigh);
            const __m128 h0 = _mm_mul_ps(h, invLow), h1 = _mm_mul_ps(h, invHigh);
            entry = _mm_max_ps(entry, _mm_min_ps(_mm_min_ps(l0, l1), _mm_min_ps(h0, h1)));
            exit = _mm_min_ps(exit, _mm_max_ps(_mm_max_ps(l0, l1), _mm_max_ps(h0, h1)));
        }
        pass = _mm_and_ps(pass, _mm_cmple_ps(entry, exit));
        _mm_storeu_ps(out.nearW.data(), _mm_max_ps(mNearestW.atCorners(n), entry));
        out.pass = uint32_t(_mm_movemask_ps(pass)) & ((1u << n.lanes) - 1u);
        auto fromEye = [half = _mm_set1_ps(0.5f)](const std::array<float, 4>& lo,
                                                  const std::array<float, 4>& hi, float e) {
            const __m128 centre =
                _mm_mul_ps(half, _mm_add_ps(_mm_loadu_ps(lo.data()), _mm_loadu_ps(hi.data())));
            return _mm_sub_ps(centre, _mm_set1_ps(e));
        };
        const __m128 dx = fromEye(n.loX, n.hiX, eye.x), dy = fromEye(n.loY, n.hiY, eye.y),
                     dz = fromEye(n.loZ, n.hiZ, eye.z);
        _mm_storeu_ps(
            out.order.data(),
            _mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)), _mm_mul_ps(dz, dz)));
#else
        const Vec3 eye = mFrame.camera.eyePos();
        for (int k = 0; k < n.lanes; ++k) {
            const Aabb box = n.box(size_t(k));
            if (mRayMode) {
                const float entry = rayEntry(box);
                out.nearW[size_t(k)] = entry;
                out.order[size_t(k)] = entry;
                if (entry < std::numeric_limits<float>::infinity() && !mFront.inFront(box))
                    out.pass |= 1u << k;
                continue;
            }
            const auto [entry, exit] = bundleSlabs(box);
            out.nearW[size_t(k)] = std::max(nearestW(box), entry);
            if (mFrustum.mayCoverBox(box, mPlaneCount) && !mFront.inFront(box) && entry <= exit)
                out.pass |= 1u << k;
            const Vec3 d = box.center() - eye;
            out.order[size_t(k)] = d.x * d.x + d.y * d.y + d.z * d.z;
        }
#endif
        return out;
    }

#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
    // testLanes on the samples' rays: rayEntry four lanes at a time.
    LaneTest testLanesOnRay(const WideBoxNode& n) const {
        LaneTest out;
        const __m128 farW = mFrontPlane.atCorners(n);
        const __m128 widen =
            _mm_mul_ps(_mm_max_ps(farW, _mm_setzero_ps()), _mm_set1_ps(mRays.widenPerW));
        // Per axis, the widened box's sides less the eye.
        auto sides = [&](const std::array<float, 4>& lo, const std::array<float, 4>& hi, float o,
                         __m128* low, __m128* high) {
            *low = _mm_sub_ps(_mm_sub_ps(_mm_loadu_ps(lo.data()), widen), _mm_set1_ps(o));
            *high = _mm_sub_ps(_mm_add_ps(_mm_loadu_ps(hi.data()), widen), _mm_set1_ps(o));
        };
        __m128 lx, hx, ly, hy, lz, hz;
        const Vec3 eye = mFrame.camera.eyePos();
        sides(n.loX, n.hiX, eye.x, &lx, &hx);
        sides(n.loY, n.hiY, eye.y, &ly, &hy);
        sides(n.loZ, n.hiZ, eye.z, &lz, &hz);
        const __m128 infinity = _mm_set1_ps(std::numeric_limits<float>::infinity());
        __m128 nearest = infinity;
        for (int r = 0; r < mRays.count; ++r) {
            const Vec3& inv = mRays.invDir[size_t(r)];
            __m128 entry = _mm_set1_ps(mNearPlane), exit = infinity;
            auto slab = [&](__m128 low, __m128 high, float i) {
                const __m128 t0 = _mm_mul_ps(low, _mm_set1_ps(i));
                const __m128 t1 = _mm_mul_ps(high, _mm_set1_ps(i));
                entry = _mm_max_ps(entry, _mm_min_ps(t0, t1));
                exit = _mm_min_ps(exit, _mm_max_ps(t0, t1));
            };
            slab(lx, hx, inv.x);
            slab(ly, hy, inv.y);
            slab(lz, hz, inv.z);
            const __m128 hit = _mm_cmple_ps(entry, exit);
            nearest = _mm_min_ps(nearest,
                                 _mm_or_ps(_mm_and_ps(hit, entry), _mm_andnot_ps(hit, infinity)));
        }
        __m128 pass = _mm_cmplt_ps(nearest, infinity);
        if (mFront.frontW() != 0.0f)
            pass = _mm_and_ps(pass, _mm_cmpnlt_ps(farW, _mm_set1_ps(mFront.frontW())));
        _mm_storeu_ps(out.nearW.data(), nearest);
        _mm_storeu_ps(out.order.data(), nearest);
        out.pass = uint32_t(_mm_movemask_ps(pass)) & ((1u << n.lanes) - 1u);
        return out;
    }
#endif

    // Tests a node's lanes and pushes those that pass, farthest first so that the nearest is
    // taken next. Returns the new top.
    size_t pushLanes(const WideBoxNode& n, Entry* stack, size_t top) {
        mStats->boxNodesTested += n.lanes;
        const LaneTest t = testLanes(n);
        std::array<std::pair<float, int>, 4> order;
        int count = 0;
        for (int k = 0; k < n.lanes; ++k) {
            if (!(t.pass >> k & 1u) || hidden(t.nearW[size_t(k)])) continue;
            // Insertion into farthest-first order.
            const std::pair<float, int> lane{t.order[size_t(k)], k};
            int at = count++;
            for (; at > 0 && order[size_t(at - 1)].first < lane.first; --at)
                order[size_t(at)] = order[size_t(at - 1)];
            order[size_t(at)] = lane;
        }
        for (int i = 0; i < count; ++i) {
            const size_t k = size_t(order[size_t(i)].second);
            stack[top++] = {n.first[k], n.count[k], t.nearW[k]};
        }
        return top;
    }

    // The frustum and front tests of four entries from `entry` on (both independent of what the
    // piece holds), and each one's smallest clip w, with the scalar tests' operations in their
    // order (RectFrustum::mayCoverPoints, FrontBound::inFront, clipW).
    struct TriangleTest {
        uint32_t pass = 0;  // bit per entry
        std::array<float, 4> nearW{};
    };
    TriangleTest testTriangles(uint32_t entry, uint32_t lanes) const {
        TriangleTest out;
        const LeafCorners& c = mFrame.fill.boxCorners;
#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
        __m128 x[3], y[3], z[3];
        for (size_t k = 0; k < 3; ++k) {
            x[k] = _mm_loadu_ps(c.x[k].data() + entry);
            y[k] = _mm_loadu_ps(c.y[k].data() + entry);
            z[k] = _mm_loadu_ps(c.z[k].data() + entry);
        }
        auto anyAtLeast = [&](const LanePlane& p, __m128 limit) {
            return _mm_or_ps(_mm_or_ps(_mm_cmpge_ps(p.at(x[0], y[0], z[0]), limit),
                                       _mm_cmpge_ps(p.at(x[1], y[1], z[1]), limit)),
                             _mm_cmpge_ps(p.at(x[2], y[2], z[2]), limit));
        };
        __m128 pass = _mm_castsi128_ps(_mm_set1_epi32(-1));
        for (size_t i = 0; i < mPlaneCount; ++i)
            pass = _mm_and_ps(pass, anyAtLeast(mLanePlanes[i], _mm_setzero_ps()));
        if (mFront.frontW() != 0.0f)
            pass = _mm_and_ps(pass, anyAtLeast(mFrontPlane, _mm_set1_ps(mFront.frontW())));
        _mm_storeu_ps(out.nearW.data(), _mm_min_ps(_mm_min_ps(mFrontPlane.at(x[0], y[0], z[0]),
                                                              mFrontPlane.at(x[1], y[1], z[1])),
                                                   mFrontPlane.at(x[2], y[2], z[2])));
        out.pass = uint32_t(_mm_movemask_ps(pass)) & ((1u << lanes) - 1u);
#else
        for (uint32_t k = 0; k < lanes; ++k) {
            const std::array<Vec3, 3> corners = c.triangle(entry + k);
            float w = std::numeric_limits<float>::infinity();
            for (const Vec3& p : corners) w = std::min(w, clipW(p));
            out.nearW[k] = w;
            if (mFrustum.mayCoverPoints(corners, mPlaneCount) && !mFront.inFront(corners))
                out.pass |= 1u << k;
        }
#endif
        return out;
    }

    // A leaf's entries, four at a time through the tests above and the projection's box test,
    // then one by one in order through the hidden test (the piece changes as they are drawn),
    // the rest of the projection test and the depth-tested scan conversion into the spans.
    void visitLeaf(uint32_t first, uint32_t count) {
        mStats->polygonsTested += count;
        for (uint32_t group = first; group < first + count; group += 4) {
            const uint32_t lanes = std::min<uint32_t>(4, first + count - group);
            const TriangleTest t = testTriangles(group, lanes);
            if (t.pass == 0) continue;
            // The projection pre-test, its box part four at a time: most triangles that reach
            // it stop there.
            const FourTriangles four =
                projectFourTriangles(mFrame.camera, mFrame.fill.boxCorners, group, mRect);
            const uint32_t pass = t.pass & ~four.missBox;
            for (uint32_t k = 0; k < lanes; ++k) {
                if (!(pass >> k & 1u) || hidden(t.nearW[k])) continue;
                // The exact span test decides the rest, on the corners the tests above read:
                // the mesh is read only for a triangle it passes.
                const uint32_t triangle = mFrame.fill.boxes.triangles()[group + k];
                const std::array<Vec3, 3> corners = mFrame.fill.boxCorners.triangle(group + k);
                bool setUp = false;
                const int64_t written =
                    raster::drawTriangleInSpans(mFrame.scene, triangle, corners, mFrame.camera,
                                                mFrame.render, mFrame.targets, mSpans, &setUp);
                mStats->polygonsDrawn += setUp;
                if (written > 0) update();
            }
        }
    }

    // After a draw: moves the cursor past the pixels now filled (a filled pixel stays filled, so
    // the piece's pixels are scanned once while it is open), and once none is empty, takes the
    // farthest 1/w drawn (the depth target holds 1/w), which later draws can only raise.
    void update() {
        if (!mFull) {
            const ImageView<uint32_t>& id = mFrame.targets.id;
            for (; mCursorSpan < mSpans.size(); ++mCursorSpan, mCursorX = kSpanStart) {
                const PixelSpan& s = mSpans[mCursorSpan];
                for (mCursorX = std::max(mCursorX, s.x0); mCursorX <= s.x1; ++mCursorX)
                    if (id.at(mCursorX, s.y) == 0) return;
            }
            mFull = true;
        }
        mFarthest = std::numeric_limits<float>::infinity();
        for (const PixelSpan& s : mSpans)
            for (int x = s.x0; x <= s.x1; ++x)
                mFarthest = std::min(mFarthest, mFrame.targets.depth.at(x, s.y));
    }

    // Whether geometry whose smallest clip w is `w` lies wholly behind every pixel of a full
    // piece: its largest 1/w, widened by the slack, below the farthest 1/w drawn. Geometry
    // reaching nearer than the near plane is never hidden.
    bool hidden(float w) const {
        return mFull && w > mNearPlane && (1.0f + kHiddenSlack) < mFarthest * w;
    }

    float clipW(const Vec3& p) const {
        return mRowW.x * p.x + mRowW.y * p.y + mRowW.z * p.z + mRowW.w;
    }
    // Smallest (or largest) clip w over a box: the corner minimising (or maximising) the linear
    // function, in LanePlane::atCorners' order.
    float nearestW(const Aabb& b) const {
        return cornerW(b, false);
    }
    float farthestW(const Aabb& b) const {
        return cornerW(b, true);
    }
    float cornerW(const Aabb& b, bool farthest) const {
        return mRowW.x * ((mRowW.x >= 0.0f) != farthest ? b.lo.x : b.hi.x) +
               mRowW.y * ((mRowW.y >= 0.0f) != farthest ? b.lo.y : b.hi.y) +
               mRowW.z * ((mRowW.z >= 0.0f) != farthest ? b.lo.z : b.hi.z) + mRowW.w;
    }
    // The smallest clip w (at least the near plane's) where one of the samples' rays, widened
    // for the box, enters it; infinity when every ray misses it.
    float rayEntry(const Aabb& b) const {
        const float widen = std::max(farthestW(b), 0.0f) * mRays.widenPerW;
        const Vec3 eye = mFrame.camera.eyePos();
        const Vec3 low = (b.lo - Vec3(widen)) - eye;
        const Vec3 high = (b.hi + Vec3(widen)) - eye;
        float nearest = std::numeric_limits<float>::infinity();
        for (int r = 0; r < mRays.count; ++r) {
            const Vec3& inv = mRays.invDir[size_t(r)];
            float entry = mNearPlane, exit = std::numeric_limits<float>::infinity();
            for (int a = 0; a < 3; ++a) {
                const float t0 = low[a] * inv[a], t1 = high[a] * inv[a];
                entry = std::max(entry, std::min(t0, t1));
                exit = std::min(exit, std::max(t0, t1));
            }
            if (entry <= exit) nearest = std::min(nearest, entry);
        }
        return nearest;
    }
    // The clip w (at least the near plane's) from which the bundle may reach the box on every
    // bounded axis, and up to which it may: it misses the box when the first exceeds the second.
    std::pair<float, float> bundleSlabs(const Aabb& b) const {
        const Vec3 eye = mFrame.camera.eyePos();
        float entry = mNearPlane, exit = std::numeric_limits<float>::infinity();
        for (size_t a = 0; a < 3; ++a) {
            if (!mBundle.bounded[a]) continue;
            const float l = b.lo[int(a)] - eye[int(a)], h = b.hi[int(a)] - eye[int(a)];
            const float l0 = l * mBundle.invLow[a], l1 = l * mBundle.invHigh[a];
            const float h0 = h * mBundle.invLow[a], h1 = h * mBundle.invHigh[a];
            entry = std::max(entry, std::min(std::min(l0, l1), std::min(h0, h1)));
            exit = std::min(exit, std::max(std::max(l0, l1), std::max(h0, h1)));
        }
        return {entry, exit};
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
    scene::PixelRect mRect;  // the spans' box
    scene::RectFrustum mFrustum;
    size_t mPlaneCount;  // the frustum's planes the tests need, from the first
#if defined(__SSE2__) && !defined(PLX_NO_SIMD)
    std::array<LanePlane, scene::RectFrustum::kPlanes>
        mLanePlanes;        // the first mPlaneCount, far corners
    LanePlane mFrontPlane;  // the clip-w row at the far corners (FrontBound)
    LanePlane mNearestW;    // the clip-w row at the near corners (nearestW)
#endif
    float mNearPlane;
    Vec4 mRowW;
    bool mRayMode = false;  // a piece of at most SampleRays::kMax pixels, searched along mRays
    SampleRays mRays{};
    RayBundle mBundle{};  // the rectangle's rays, for a piece not in mRayMode
    FrontBound mFront;
    // The first pixel not yet seen filled, in span order: (span index, column), the column
    // kSpanStart for the span's first.
    static constexpr int kSpanStart = std::numeric_limits<int>::min();
    size_t mCursorSpan = 0;
    int mCursorX = kSpanStart;
    bool mFull = false;  // no pixel of the spans left empty
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

std::vector<WideBoxNode> collapseFourWide(const scene::BoxHierarchy& boxes) {
    std::vector<WideBoxNode> wide;
    if (boxes.nodeCount() == 0) return wide;
    // (binary inner node or leaf, its WideBoxNode): a node waiting for its lanes.
    std::vector<std::pair<uint32_t, uint32_t>> pending{{0u, 0u}};
    wide.emplace_back();
    while (!pending.empty()) {
        const auto [binary, index] = pending.back();
        pending.pop_back();
        // The lanes: a leaf root is its own one lane; else the children, each inner child
        // replaced by its two children.
        std::array<uint32_t, 4> lanes{};
        int count = 0;
        const scene::BoxNode& node = boxes.node(binary);
        if (node.isLeaf()) {
            lanes[size_t(count++)] = binary;
        } else {
            for (uint32_t child : {binary + 1, node.first}) {
                const scene::BoxNode& c = boxes.node(child);
                if (c.isLeaf()) {
                    lanes[size_t(count++)] = child;
                } else {
                    lanes[size_t(count++)] = child + 1;
                    lanes[size_t(count++)] = c.first;
                }
            }
        }
        WideBoxNode out;
        out.lanes = uint8_t(count);
        for (size_t k = 0; k < size_t(count); ++k) {
            const scene::BoxNode& lane = boxes.node(lanes[k]);
            out.loX[k] = lane.box.lo.x;
            out.loY[k] = lane.box.lo.y;
            out.loZ[k] = lane.box.lo.z;
            out.hiX[k] = lane.box.hi.x;
            out.hiY[k] = lane.box.hi.y;
            out.hiZ[k] = lane.box.hi.z;
            if (lane.isLeaf()) {
                out.first[k] = lane.first;
                out.count[k] = uint16_t(lane.count);
            } else {
                out.first[k] = uint32_t(wide.size());
                wide.emplace_back();
                pending.push_back({lanes[k], out.first[k]});
            }
        }
        wide[index] = out;
    }
    return wide;
}

void searchBoxHierarchy(const BoxSearchFrame& frame, std::span<const PixelSpan> spans,
                        FillStats* stats) {
    if (spans.empty()) return;
    BoxSearch(frame, spans, stats).run();
}

}  // namespace plx::stereo
