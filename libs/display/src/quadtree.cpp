// RecursiveGridRefinement with GeneratePatch, TransformPatchVertices and RefineFurther
// (Bimber et al. Algorithm 1, sections 5-7), LOD balancing, T-counter triangulation, the uniform
// baseline and the crack check.

#include <plx/display/quadtree.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <unordered_map>
#include <unordered_set>

namespace plx::display {
namespace {

constexpr double kPiD = 3.141592653589793;

enum NodeState : uint8_t { kAbsent = 0, kLeaf = 1, kRefined = 2, kCulled = 3 };

// The representative of angle (mod 2 pi) nearest to reference. Angles from atan2 lie within a
// few turns of any bracket, so a short loop is cheaper than std::remainder.
double unwrapNear(double angle, double reference) {
    double d = angle - reference;
    if (!std::isfinite(d)) return reference;
    if (std::fabs(d) > 8.0 * kPiD) return reference + std::remainder(d, 2.0 * kPiD);
    while (d > kPiD) d -= 2.0 * kPiD;
    while (d < -kPiD) d += 2.0 * kPiD;
    return reference + d;
}

// Separating axis test of an axis-aligned rectangle against a convex polygon (counter-clockwise
// or clockwise, at least three points).
bool rectOverlapsConvex(DVec2 lo, DVec2 hi, const std::vector<DVec2>& poly) {
    DVec2 pmin(1e300), pmax(-1e300);
    for (const DVec2& p : poly) pmin = glm::min(pmin, p), pmax = glm::max(pmax, p);
    if (pmax.x < lo.x || pmin.x > hi.x || pmax.y < lo.y || pmin.y > hi.y) return false;
    DVec2 corners[4] = {lo, {hi.x, lo.y}, hi, {lo.x, hi.y}};
    size_t n = poly.size();
    for (size_t i = 0; i < n; ++i) {
        DVec2 e = poly[(i + 1) % n] - poly[i];
        DVec2 axis(-e.y, e.x);
        double p0 = 1e300, p1 = -1e300, r0 = 1e300, r1 = -1e300;
        for (const DVec2& p : poly) {
            double s = glm::dot(axis, p);
            p0 = std::min(p0, s), p1 = std::max(p1, s);
        }
        for (const DVec2& c : corners) {
            double s = glm::dot(axis, c);
            r0 = std::min(r0, s), r1 = std::max(r1, s);
        }
        if (r1 < p0 || r0 > p1) return false;
    }
    return true;
}

// Andrew's monotone chain: convex hull of 2D points, counter-clockwise.
std::vector<DVec2> convexHull2d(std::vector<DVec2> pts) {
    std::sort(pts.begin(), pts.end(),
              [](const DVec2& a, const DVec2& b) { return a.x < b.x || (a.x == b.x && a.y < b.y); });
    if (pts.size() < 3) return pts;
    std::vector<DVec2> hull(2 * pts.size());
    size_t k = 0;
    auto cross = [](DVec2 o, DVec2 a, DVec2 b) {
        return (a.x - o.x) * (b.y - o.y) - (a.y - o.y) * (b.x - o.x);
    };
    for (size_t i = 0; i < pts.size(); ++i) {
        while (k >= 2 && cross(hull[k - 2], hull[k - 1], pts[i]) <= 0) --k;
        hull[k++] = pts[i];
    }
    for (size_t i = pts.size() - 1, t = k + 1; i > 0; --i) {
        while (k >= t && cross(hull[k - 2], hull[k - 1], pts[i - 1]) <= 0) --k;
        hull[k++] = pts[i - 1];
    }
    hull.resize(k - 1);
    return hull;
}

// Empties a mesh but keeps its buffers, so that regenerating it each frame allocates nothing.
void clearKeepingCapacity(WarpMesh* mesh) {
    mesh->gridIds.clear();
    mesh->uvs.clear();
    mesh->displayPos.clear();
    mesh->indices.clear();
}

}  // namespace

struct QuadtreeWarper::Impl {
    QuadtreeConfig config;
    int m = 0;
    int side = 0;  // 2^m + 1
    uint32_t frame = 0;
    // Per vertex of the matrix, this frame's cached work: the marker flags of section 6 and the
    // results they guard. A frame touches a few thousand of the (2^m + 1)^2 vertices, scattered
    // over the matrix, so the states live in a compact per-frame array in the order the
    // recursion first touches them (neighbouring patches' vertices end up near each other), and
    // the matrix holds only an 8-byte slot per vertex: its stamp and the state's index. A stamp
    // equal to `frame` marks the slot as this frame's, so advancing the frame number clears
    // every flag for free. (One 64-byte state per matrix vertex, 17 MB at m = 9, made the first
    // touch of each vertex a cache and TLB miss: about 40% of the recursion's time.)
    enum VertexFlag : uint8_t {
        kTransformed = 1,  // mapping holds this frame's TransformPatchVertices result
        kSolverOnly = 2,   // mapped by the error solver, not yet counted as a vt
        kRayDone = 4,      // line-of-sight/container result cached
        kRayHit = 8,
        kInMesh = 16,      // emitted into the mesh at meshIndex
        kErrorDone = 32,   // errorValue holds the side error sampled at this T-vertex
    };
    struct VertexState {
        VertexMapping mapping;
        double errorValue = 0.0;
        uint32_t meshIndex = 0;
        uint8_t flags = 0;
        uint8_t tc = 0;  // T-vertex counter (0, 1, 2)
    };
    struct VertexSlot {
        uint32_t stamp = 0;
        uint32_t index = 0;  // into states, valid when stamp == frame
    };
    std::vector<VertexSlot> slots;    // per matrix vertex
    std::vector<VertexState> states;  // this frame's touched vertices; capacity for all of
                                      // them, so references stay valid while it grows
    // Node states per LOD 0 .. m-1 (4^n nodes each).
    std::vector<std::vector<uint8_t>> nodes;
    // Per LOD, the nodes this frame made present (py << 16 | px): balancing, triangulation and
    // the reset of the next frame visit these instead of scanning all 4^n nodes of each LOD.
    std::vector<std::vector<uint32_t>> touched;

    // Per frame.
    const Display* display = nullptr;
    const ImagePlane* plane = nullptr;
    const Container* container = nullptr;
    bool culling = false;
    // Front-facing container triangles, prepared for rays from the eye.
    std::vector<TriangleFromOrigin> frontTriangles;
    size_t lastHitTriangle = 0;            // neighbouring lines of sight hit the same triangle
    DVec2 silhouetteLo{0.0}, silhouetteHi{0.0};  // bounding box of `projected`, widened a little
    std::vector<DVec2> frontVertexUvs;     // front-facing container vertices on the image plane
    std::vector<DVec2> silhouette;         // convex outline of the projected container
    std::vector<uint8_t> front;            // per container vertex: on a front-facing triangle
    std::vector<DVec2> projected;          // container vertices on the image plane
    WarpStats* stats = nullptr;
    WarpMesh* mesh = nullptr;

    uint32_t vid(int x, int y) const { return uint32_t(y) * uint32_t(side) + uint32_t(x); }
    // The vertex's state for this frame (flags and counter cleared on first touch).
    VertexState& vertex(uint32_t v) {
        VertexSlot& slot = slots[v];
        if (slot.stamp != frame) {
            slot.stamp = frame;
            slot.index = uint32_t(states.size());
            states.emplace_back();
        }
        return states[slot.index];
    }
    // A vertex transformed this frame.
    const VertexMapping& mapping(int x, int y) const {
        const VertexSlot& slot = slots[vid(x, y)];
        PLX_DCHECK(slot.stamp == frame);
        return states[slot.index].mapping;
    }
    DVec2 uvOf(int x, int y) const {
        double s = 1.0 / double(side - 1);
        return {x * s, y * s};
    }
    int patchSize(int level) const { return 1 << (m - level); }
    uint8_t& node(int level, int px, int py) { return nodes[level][size_t(py << level) + px]; }
    void setNode(int level, int px, int py, uint8_t state) {
        uint8_t& n = node(level, px, py);
        if (n == kAbsent) touched[level].push_back(uint32_t(py) << 16 | uint32_t(px));
        n = state;
    }

    // TransformPatchVertices for one vertex: mapped once per frame. A vertex that the error
    // solver already mapped (a T-vertex, see sideError) is reused and counted now.
    const VertexMapping& transformVertex(int x, int y) {
        VertexState& s = vertex(vid(x, y));
        if (!(s.flags & kTransformed)) {
            s.flags |= kTransformed;
            s.mapping = imageToDisplay(*display, *plane, plane->pointAt(uvOf(x, y)));
            ++stats->vertexTransformations;
        } else if (s.flags & kSolverOnly) {
            s.flags &= uint8_t(~kSolverOnly);
            ++stats->vertexTransformations;
        }
        return s.mapping;
    }

    // The same mapping made for the error solver: cached like a transformation, but counted as
    // a vertex transformation only if the vertex later joins the grid.
    const VertexMapping& mapForSolver(int x, int y) {
        VertexState& s = vertex(vid(x, y));
        if (!(s.flags & kTransformed)) {
            s.flags |= kTransformed | kSolverOnly;
            s.mapping = imageToDisplay(*display, *plane, plane->pointAt(uvOf(x, y)));
            ++stats->solver.forwardEvaluations;
        }
        return s.mapping;
    }

    // Object-image solve for one sample (section 7.3) by Newton steps on the forward mapping:
    // find texture coordinates uv whose display image is `target`, starting at the T-vertex
    // (whose image is close to the sample, the two differ by the warp's interpolation error),
    // with the patch's finite-difference Jacobian jac (display per uv) refined by Broyden's
    // update. Converged when the display mismatch Delta is below kObjectImageToleranceMm, the
    // same acceptance as Brent's method. Returns false (the caller falls back to Brent) when a
    // step leaves the patch, a mapping fails or four steps do not converge.
    bool newtonImageUv(int tx, int ty, const DVec2& target, glm::dmat2 jac, double patchUv,
                       DVec2* uvOut) {
        const VertexMapping& tm = mapForSolver(tx, ty);
        if (!tm.valid) return false;
        DVec2 uv0 = uvOf(tx, ty), uv = uv0, pos = tm.displayPos;
        constexpr int kMaxNewtonSteps = 4;
        constexpr double kTolSq = kObjectImageToleranceMm * kObjectImageToleranceMm;
        for (int step = 0;; ++step) {
            DVec2 r = target - pos;
            if (glm::dot(r, r) <= kTolSq) {
                *uvOut = uv;
                return true;
            }
            if (step == kMaxNewtonSteps) return false;
            double det = glm::determinant(jac);
            if (!(std::fabs(det) > 1e-12)) return false;
            DVec2 du = glm::inverse(jac) * r;
            DVec2 next = uv + du;
            if (glm::length(next - uv0) > patchUv) return false;
            VertexMapping vm = imageToDisplay(*display, *plane, plane->pointAt(next));
            ++stats->solver.forwardEvaluations;
            if (!vm.valid) return false;
            DVec2 dPos = vm.displayPos - pos;
            jac += glm::outerProduct(dPos - jac * du, du) / glm::dot(du, du);
            uv = next, pos = vm.displayPos;
        }
    }

    void bumpCounter(int x, int y) {
        ++vertex(vid(x, y)).tc;
    }
    int counter(int x, int y) const {
        const VertexSlot& slot = slots[vid(x, y)];
        return slot.stamp == frame ? states[slot.index].tc : 0;
    }

    void prepareContainer() {
        frontTriangles.clear();
        frontVertexUvs.clear();
        silhouette.clear();
        culling = container && container->triangleCount() > 0;
        if (!culling) return;
        const DVec3 eye = plane->eyeMm;
        front.assign(container->verticesMm.size(), 0);
        projected.clear();
        for (const DVec3& p : container->verticesMm) {
            DVec3 onPlane;
            if (!plane->projectFromEye(p, &onPlane)) {
                culling = false;  // the eye is inside or beside the container: cull nothing
                return;
            }
            projected.push_back(plane->uvOf(onPlane));
        }
        for (size_t t = 0; t < container->triangleCount(); ++t) {
            const uint32_t* idx = &container->indices[3 * t];
            const DVec3& a = container->verticesMm[idx[0]];
            DVec3 n = glm::cross(container->verticesMm[idx[1]] - a,
                                 container->verticesMm[idx[2]] - a);
            if (glm::dot(n, a - eye) >= 0.0) continue;  // back-facing
            frontTriangles.push_back(prepareFromOrigin(eye, a, container->verticesMm[idx[1]],
                                                       container->verticesMm[idx[2]]));
            for (int k = 0; k < 3; ++k) front[idx[k]] = 1;
        }
        for (size_t i = 0; i < front.size(); ++i)
            if (front[i]) frontVertexUvs.push_back(projected[i]);
        silhouette = convexHull2d(projected);
        lastHitTriangle = 0;
        // A line of sight that meets the container meets it at a point whose projection lies in
        // the silhouette, so one outside the silhouette's box hits no triangle. The margin (about
        // 3e-4 mm on the plane) is far wider than the rounding of the projection or the ray
        // test's 1e-9 barycentric tolerance, so the box only skips tests that would all miss.
        constexpr double kMarginUv = 1e-6;
        silhouetteLo = DVec2(1e300), silhouetteHi = DVec2(-1e300);
        for (const DVec2& p : projected)
            silhouetteLo = glm::min(silhouetteLo, p), silhouetteHi = glm::max(silhouetteHi, p);
        silhouetteLo -= kMarginUv, silhouetteHi += kMarginUv;
    }

    // Moller-Trumbore tests of one line of sight against the front triangles, starting with the
    // one the previous line of sight hit (any hit decides, so the order changes only the count).
    bool sightHitsFrontTriangle(const DVec3& dir) {
        size_t n = frontTriangles.size();
        for (size_t i = 0; i < n; ++i) {
            size_t k = lastHitTriangle + i < n ? lastHitTriangle + i : lastHitTriangle + i - n;
            double tHit;
            ++stats->containerRayTests;
            if (intersectFromOrigin(frontTriangles[k], dir, &tHit)) {
                lastHitTriangle = k;
                return true;
            }
        }
        return false;
    }

    // First test of section 7.1 for one L-vertex: the line of sight from the eye through it
    // against the front-facing container triangles (Moller-Trumbore), cached per vertex.
    bool lineOfSightHits(int x, int y) {
        VertexState& s = vertex(vid(x, y));
        if (s.flags & kRayDone) return (s.flags & kRayHit) != 0;
        DVec2 uv = uvOf(x, y);
        bool inBox = uv.x >= silhouetteLo.x && uv.x <= silhouetteHi.x && uv.y >= silhouetteLo.y &&
                     uv.y <= silhouetteHi.y;
        bool hit = inBox && sightHitsFrontTriangle(plane->pointAt(uv) - plane->eyeMm);
        s.flags |= uint8_t(kRayDone | (hit ? kRayHit : 0));
        return hit;
    }

    // GeneratePatch (section 7.1): whether the container can be visible on the patch.
    bool generatePatch(int level, int px, int py) {
        if (!culling) return true;
        int h = patchSize(level);
        int x0 = px * h, y0 = py * h, x1 = x0 + h, y1 = y0 + h;
        if (lineOfSightHits(x0, y0) || lineOfSightHits(x1, y0) || lineOfSightHits(x1, y1) ||
            lineOfSightHits(x0, y1))
            return true;
        // Second test: lines of sight to the front-facing container vertices through the patch.
        DVec2 lo = uvOf(x0, y0), hi = uvOf(x1, y1);
        for (const DVec2& p : frontVertexUvs)
            if (p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y) return true;
        // The two ray tests miss a patch crossed by a container edge with no corner and no
        // container vertex inside it; the silhouette overlap closes that gap so that no patch
        // showing the container is lost.
        return rectOverlapsConvex(lo, hi, silhouette);
    }

    // Image space error at the T-vertex of side (a, b). Both patches sharing a side sample the
    // same point, so the result is cached per T-vertex for the frame (like the transformations).
    // jac: the patch's Jacobian (display per uv) for the Newton solve; patchUv its side in uv.
    double sideError(int ax, int ay, int bx, int by, const glm::dmat2& jac, double patchUv,
                     const AlphaBracket& parentBracket) {
        int tx = (ax + bx) / 2, ty = (ay + by) / 2;
        VertexState& ts = vertex(vid(tx, ty));
        if (ts.flags & kErrorDone) return ts.errorValue;
        const VertexMapping& a = mapping(ax, ay);
        const VertexMapping& b = mapping(bx, by);
        ++stats->errorSamples;
        // The pixel with the T-vertex's texture coordinates lies at the middle of the displayed
        // L-L edge (linear interpolation), section 7.2 / Fig. 4.
        DVec2 samplePos = 0.5 * (a.displayPos + b.displayPos);
        DVec2 desiredUv = uvOf(tx, ty);
        double e;
        DVec2 actualUv;
        if (usesMirrorAngles(*display) &&
            newtonImageUv(tx, ty, samplePos, jac, patchUv, &actualUv)) {
            // Image space error |v_d - v_a| on the image plane (section 7.2).
            ++stats->solver.newtonSolves;
            e = glm::length(plane->pointAt(actualUv) - plane->pointAt(desiredUv));
        } else {
            AlphaBracket bracket = parentBracket;
            if (usesMirrorAngles(*display)) {
                // Start from the mean of the edge's end angles: the sample lies between them.
                double a0 = unwrapNear(a.alpha, parentBracket.lo);
                double a1 = unwrapNear(b.alpha, parentBracket.lo);
                bracket.guess = 0.5 * (a0 + a1);
            }
            e = sampleErrorMm(*display, *plane, samplePos, desiredUv, bracket, &stats->solver);
        }
        ts.flags |= kErrorDone;
        ts.errorValue = e;
        return e;
    }

    // RefineFurther (sections 7.2-7.4). dir: in = the parent's error direction, out = this
    // patch's.
    bool refineFurther(int level, int x0, int y0, int h, const AlphaBracket& bracket, int* dir) {
        if (level < config.minLevel) return true;
        int x1 = x0 + h, y1 = y0 + h;
        const int sides[4][4] = {{x0, y0, x1, y0}, {x1, y0, x1, y1}, {x1, y1, x0, y1},
                                 {x0, y1, x0, y0}};
        // Finite-difference Jacobian of the warp over the patch (display per uv), from the four
        // L-vertices TransformPatchVertices has just mapped.
        double patchUv = double(h) / double(side - 1);
        const DVec2& d00 = mapping(x0, y0).displayPos;
        const DVec2& d10 = mapping(x1, y0).displayPos;
        const DVec2& d11 = mapping(x1, y1).displayPos;
        const DVec2& d01 = mapping(x0, y1).displayPos;
        glm::dmat2 jac(((d10 - d00) + (d11 - d01)) / (2.0 * patchUv),
                       ((d01 - d00) + (d11 - d10)) / (2.0 * patchUv));
        double worst = -1.0;
        if (level >= config.errorDirectionLevel && *dir >= 0) {
            // Section 7.4: above Lambda only the parent's largest-error side is evaluated.
            const int* s = sides[*dir];
            worst = sideError(s[0], s[1], s[2], s[3], jac, patchUv, bracket);
            if (worst > config.thresholdMm) return true;
            // Safety re-check: a patch about to stop whose error in the inherited direction is
            // close to the threshold samples its other sides too, in case the direction of the
            // largest error has turned (the heuristic's assumption, checked where it matters).
            if (worst <= config.errorDirectionRecheck * config.thresholdMm) return false;
        }
        for (int k = 0; k < 4; ++k) {
            const int* s = sides[k];
            double e = sideError(s[0], s[1], s[2], s[3], jac, patchUv, bracket);
            if (e > worst) worst = e, *dir = k;
            // One side over the threshold decides; the rest are needed only as the error
            // direction of children at LOD >= Lambda. A refined patch's T-vertices become its
            // children's L-vertices, so the skipped samples are never needed.
            if (worst > config.thresholdMm && level + 1 < config.errorDirectionLevel) return true;
        }
        return worst > config.thresholdMm;
    }

    // Transforms the four L-vertices and the X-vertex; false when one cannot be mapped.
    bool transformPatchVertices(int x0, int y0, int h, AlphaBracket* range) {
        int c = h / 2;
        const int pts[5][2] = {{x0, y0}, {x0 + h, y0}, {x0 + h, y0 + h}, {x0, y0 + h},
                               {x0 + c, y0 + c}};
        bool ok = true;
        double ref = 0.0;
        range->lo = 1e300, range->hi = -1e300;
        for (int i = 0; i < 5; ++i) {
            const VertexMapping& vm = transformVertex(pts[i][0], pts[i][1]);
            ok = ok && vm.valid;
            if (!vm.valid) continue;
            if (range->lo > range->hi) ref = vm.alpha;
            double a = unwrapNear(vm.alpha, ref);
            range->lo = std::min(range->lo, a), range->hi = std::max(range->hi, a);
        }
        if (range->lo > range->hi) range->lo = range->hi = 0.0;
        return ok;
    }

    void countTransitions(int x0, int y0, int h) {
        int c = h / 2, x1 = x0 + h, y1 = y0 + h, last = side - 1;
        // Algorithm 1 lines 13-16; boundary T-vertices keep counter 0.
        if (y0 > 0) bumpCounter(x0 + c, y0);
        if (x1 < last) bumpCounter(x1, y0 + c);
        if (y1 < last) bumpCounter(x0 + c, y1);
        if (x0 > 0) bumpCounter(x0, y0 + c);
    }

    // Algorithm 1. parentBracket: the mirror-angle range of the parent patch (section 7.3).
    void recurse(int level, int px, int py, const AlphaBracket& parentBracket, int parentDir) {
        int h = patchSize(level);
        int x0 = px * h, y0 = py * h;
        if (!generatePatch(level, px, py)) {
            setNode(level, px, py, kCulled);
            ++stats->culledPatches;
            return;
        }
        AlphaBracket range;
        bool mapped = transformPatchVertices(x0, y0, h, &range);
        bool canRefine = level + 1 < m;
        if (!mapped) {
            // Partly outside the optics: subdivide towards the edge of what can be shown, and
            // drop what is left at the finest LOD.
            if (!canRefine) {
                setNode(level, px, py, kCulled);
                ++stats->culledPatches;
                return;
            }
        }
        ++stats->patches;
        stats->deepestLevel = std::max(stats->deepestLevel, level);
        setNode(level, px, py, kLeaf);
        AlphaBracket bracket = level == 0 ? range : parentBracket;
        int dir = parentDir;
        bool refine = !mapped || (canRefine && refineFurther(level, x0, y0, h, bracket, &dir));
        if (!refine) return;
        setNode(level, px, py, kRefined);
        for (int k = 0; k < 4; ++k)
            recurse(level + 1, 2 * px + (k & 1), 2 * py + (k >> 1), range, dir);
        countTransitions(x0, y0, h);
    }

    // Splits a leaf whose neighbour is two or more LODs finer; its children become leaves.
    void forceRefine(int level, int px, int py) {
        setNode(level, px, py, kRefined);
        ++stats->balanceRefinements;
        int h = patchSize(level);
        for (int k = 0; k < 4; ++k) {
            int cx = 2 * px + (k & 1), cy = 2 * py + (k >> 1);
            if (!generatePatch(level + 1, cx, cy)) {
                setNode(level + 1, cx, cy, kCulled);
                ++stats->culledPatches;
                continue;
            }
            AlphaBracket range;
            int ch = h / 2;
            if (!transformPatchVertices(cx * ch, cy * ch, ch, &range)) {
                setNode(level + 1, cx, cy, kCulled);
                ++stats->culledPatches;
                continue;
            }
            setNode(level + 1, cx, cy, kLeaf);
            ++stats->patches;
            stats->deepestLevel = std::max(stats->deepestLevel, level + 1);
        }
        countTransitions(px * h, py * h, h);
    }

    // Enforces the continuous LOD condition of section 5 (neighbours differ by at most one LOD):
    // every refined patch's same-LOD neighbours must exist. Finest LODs first, so refinements
    // forced at coarser LODs are checked when their own LOD is visited.
    void balance() {
        for (int level = m - 2; level >= 1; --level) {
            int count = 1 << level;
            // Index loop: refinements forced here may append to this LOD's list.
            for (size_t i = 0; i < touched[level].size(); ++i) {
                int px = int(touched[level][i] & 0xffffu), py = int(touched[level][i] >> 16);
                if (node(level, px, py) != kRefined) continue;
                const int nb[4][2] = {{px, py - 1}, {px + 1, py}, {px, py + 1}, {px - 1, py}};
                for (const auto& q : nb) {
                    if (q[0] < 0 || q[1] < 0 || q[0] >= count || q[1] >= count) continue;
                    ensureExists(level, q[0], q[1]);
                }
            }
        }
    }

    void ensureExists(int level, int px, int py) {
        while (node(level, px, py) == kAbsent) {
            // Nearest existing ancestor.
            int l = level - 1, ax = px >> 1, ay = py >> 1;
            while (l > 0 && node(l, ax, ay) == kAbsent) --l, ax >>= 1, ay >>= 1;
            uint8_t s = node(l, ax, ay);
            if (s == kCulled || s == kAbsent) return;
            PLX_CHECK(s == kLeaf);
            forceRefine(l, ax, ay);
        }
    }

    uint32_t emitVertex(int x, int y) {
        uint32_t v = vid(x, y);
        VertexState& s = vertex(v);
        if (s.flags & kInMesh) return s.meshIndex;
        const VertexMapping& vm = transformVertex(x, y);  // a T-vertex of a culled neighbour
        s.flags |= kInMesh;
        s.meshIndex = uint32_t(mesh->uvs.size());
        mesh->gridIds.push_back(v);
        mesh->uvs.push_back(uvOf(x, y));
        mesh->displayPos.push_back(vm.displayPos);
        return s.meshIndex;
    }

    // Section 6: per side one triangle (counter 0) or two through the T-vertex (counter 1).
    // A leaf's fan uses at most nine vertices, most of them in several triangles; each is looked
    // up once (in first-use order, so mesh indices are those of emitting them one by one).
    void triangulateLeaf(int level, int px, int py) {
        int h = patchSize(level), c = h / 2;
        int x0 = px * h, y0 = py * h, x1 = x0 + h, y1 = y0 + h, xc = x0 + c, yc = y0 + c;
        // Corners 0-3 (side k runs from corner k to corner k + 1), T-vertex of side k at 4 + k,
        // the X-vertex at 8.
        const int at[9][2] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}, {xc, y0},
                              {x1, yc}, {xc, y1}, {x0, yc}, {xc, yc}};
        uint32_t index[9];
        bool known[9] = {};
        auto emit = [&](int k) {
            if (!known[k]) index[k] = emitVertex(at[k][0], at[k][1]), known[k] = true;
            mesh->indices.push_back(index[k]);
        };
        for (int k = 0; k < 4; ++k) {
            int next = (k + 1) & 3, t = 4 + k;
            if (counter(at[t][0], at[t][1]) == 1) {
                emit(k), emit(t), emit(8);
                emit(t), emit(next), emit(8);
            } else {
                emit(k), emit(next), emit(8);
            }
        }
        ++stats->leafPatches;
    }

    // Triangulates the leaves below a node depth first, so that neighbouring leaves, which share
    // vertices, are emitted together while those vertices' states are still in cache.
    void triangulate(int level, int px, int py) {
        uint8_t state = node(level, px, py);
        if (state == kLeaf) {
            triangulateLeaf(level, px, py);
        } else if (state == kRefined) {
            for (int k = 0; k < 4; ++k) triangulate(level + 1, 2 * px + (k & 1), 2 * py + (k >> 1));
        }
    }

    void run(const Display& d, const ImagePlane& p, const Container* c, WarpMesh* out,
             WarpStats* st) {
        display = &d, plane = &p, container = c, mesh = out, stats = st;
        *stats = WarpStats{};
        clearKeepingCapacity(mesh);
        mesh->gridLevel = m;
        if (++frame == 0) {  // stamps wrapped: clear them once every 2^32 frames
            for (VertexSlot& s : slots) s.stamp = 0;
            frame = 1;
        }
        states.clear();
        for (int level = 0; level < m; ++level) {
            for (uint32_t packed : touched[level])
                node(level, int(packed & 0xffffu), int(packed >> 16)) = kAbsent;
            touched[level].clear();
        }
        prepareContainer();
        recurse(0, 0, 0, AlphaBracket{}, -1);
        balance();
        triangulate(0, 0, 0);
    }
};

QuadtreeWarper::QuadtreeWarper(std::unique_ptr<Impl> impl) : mImpl(std::move(impl)) {}
QuadtreeWarper::~QuadtreeWarper() = default;

Result<std::unique_ptr<QuadtreeWarper>> QuadtreeWarper::create(const QuadtreeConfig& config) {
    if (config.gridLevel < 2 || config.gridLevel > 11)
        return errorStatus(ErrorCode::kInvalidArgument,
                           "grid level " + std::to_string(config.gridLevel) +
                               " out of range [2, 11]");
    if (!std::isfinite(config.thresholdMm) || config.thresholdMm <= 0.0)
        return errorStatus(ErrorCode::kInvalidArgument,
                           "error threshold must be a positive number of millimetres");
    auto impl = std::make_unique<Impl>();
    impl->config = config;
    impl->m = config.gridLevel;
    impl->side = (1 << config.gridLevel) + 1;
    size_t count = size_t(impl->side) * size_t(impl->side);
    impl->slots.resize(count);
    // Reserved, not touched: only the pages a frame's states use are ever committed.
    impl->states.reserve(count);
    impl->nodes.resize(size_t(config.gridLevel));
    impl->touched.resize(size_t(config.gridLevel));
    for (int l = 0; l < config.gridLevel; ++l) impl->nodes[l].assign(size_t(1) << (2 * l), 0);
    return std::unique_ptr<QuadtreeWarper>(new QuadtreeWarper(std::move(impl)));
}

const QuadtreeConfig& QuadtreeWarper::config() const { return mImpl->config; }

void QuadtreeWarper::setThresholdMm(double thresholdMm) {
    PLX_CHECK(std::isfinite(thresholdMm) && thresholdMm > 0.0);
    mImpl->config.thresholdMm = thresholdMm;
}

void QuadtreeWarper::generate(const Display& display, const ImagePlane& plane,
                              const Container* container, WarpMesh* mesh, WarpStats* stats) {
    mImpl->run(display, plane, container, mesh, stats);
}

void generateUniform(const Display& display, const ImagePlane& plane, int level, WarpMesh* mesh,
                     WarpStats* stats) {
    PLX_CHECK(level >= 0 && level <= 12);
    clearKeepingCapacity(mesh);
    *stats = WarpStats{};
    mesh->gridLevel = level;
    int side = (1 << level) + 1;
    double s = 1.0 / double(side - 1);
    size_t count = size_t(side) * size_t(side);
    mesh->uvs.resize(count);
    mesh->displayPos.resize(count);
    mesh->gridIds.resize(count);
    // Vertices the optics cannot map get a NaN position, which marks their cells as left out.
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    bool anyInvalid = false;
    for (int y = 0; y < side; ++y) {
        for (int x = 0; x < side; ++x) {
            size_t v = size_t(y) * side + x;
            DVec2 uv(x * s, y * s);
            VertexMapping vm = imageToDisplay(display, plane, plane.pointAt(uv));
            mesh->uvs[v] = uv;
            mesh->displayPos[v] = vm.valid ? vm.displayPos : DVec2(kNaN);
            mesh->gridIds[v] = uint32_t(v);
            anyInvalid = anyInvalid || !vm.valid;
        }
    }
    stats->vertexTransformations = count;
    auto valid = [&](uint32_t v) { return !std::isnan(mesh->displayPos[v].x); };
    for (int y = 0; y + 1 < side; ++y) {
        for (int x = 0; x + 1 < side; ++x) {
            uint32_t a = uint32_t(y * side + x), b = a + 1, c = a + uint32_t(side), d = c + 1;
            if (!valid(a) || !valid(b) || !valid(c) || !valid(d)) continue;
            for (uint32_t i : {a, b, d, a, d, c}) mesh->indices.push_back(i);
            ++stats->leafPatches;
        }
    }
    // Unreferenced vertices keep a finite position for the exporters.
    if (anyInvalid)
        for (DVec2& p : mesh->displayPos)
            if (std::isnan(p.x)) p = DVec2(0.0);
    stats->patches = stats->leafPatches;
    stats->deepestLevel = level;
}

CrackReport checkCracks(const WarpMesh& mesh) {
    CrackReport r;
    int64_t side = (int64_t(1) << mesh.gridLevel) + 1;
    std::unordered_set<uint32_t> used(mesh.gridIds.begin(), mesh.gridIds.end());
    std::unordered_map<uint64_t, int> edges;
    for (size_t t = 0; t < mesh.indices.size(); t += 3) {
        for (int k = 0; k < 3; ++k) {
            uint32_t a = mesh.gridIds[mesh.indices[t + k]];
            uint32_t b = mesh.gridIds[mesh.indices[t + (k + 1) % 3]];
            edges[(uint64_t(std::min(a, b)) << 32) | std::max(a, b)]++;
        }
    }
    r.edges = edges.size();
    for (const auto& [key, count] : edges) {
        int64_t a = int64_t(key >> 32), b = int64_t(key & 0xffffffffu);
        int64_t ax = a % side, ay = a / side, bx = b % side, by = b / side;
        if (count > 2) ++r.overusedEdges;
        if (count == 1) {
            ++r.boundaryEdges;
            bool onBorder = (ax == bx && (ax == 0 || ax == side - 1)) ||
                            (ay == by && (ay == 0 || ay == side - 1));
            if (!onBorder) ++r.imageBorderViolations;
        }
        int64_t dx = bx - ax, dy = by - ay;
        int64_t g = std::gcd(std::llabs(dx), std::llabs(dy));
        for (int64_t k = 1; k < g; ++k) {
            int64_t x = ax + dx / g * k, y = ay + dy / g * k;
            if (used.count(uint32_t(y * side + x))) {
                ++r.tJunctions;
                break;
            }
        }
    }
    return r;
}

}  // namespace plx::display
