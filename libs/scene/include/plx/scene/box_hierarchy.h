#pragma once
// Hierarchy of enclosing boxes over a scene's triangles, built once, with the per-hole query of
// Fu, Bao, Peng (section 3): "we associate each polygon with an enclosing box and organize all
// objects in the scene into a hierarchical tree. [...] When the projected area of the enclosing
// box of a tree node is outside the hole, the flag of the node together with all nodes of its
// sub-tree will be set to a negative value without any further tests. Otherwise, we set the flag
// of the current node to a positive value and the non terminal nodes of its sub-tree are tested
// recursively. Finally, the flag of all unvisited terminal nodes are set to a positive value".
//
// Here the terminal nodes are triangles (scene-global indices), grouped in leaf buckets of up to
// BoxHierarchyConfig::leafSize; every node, buckets included, is tested. Flags live in a
// caller-owned HoleFlags that a generation counter clears in O(1): "negative" is simply a flag
// not stamped by the current query, so a rejected subtree costs nothing. A front-to-back BSP
// walk (<plx/scene/bsp.h>) then skips fragments whose source triangle is negative and applies
// the separating test (triangleMayCoverRect / polygonMayCoverRect) to the rest.
//
// Everything here is conservative: a "no" is exact (the geometry cannot reach the rectangle),
// a "yes" only means "may". Geometry crossing the camera's near plane always gets a "yes";
// geometry wholly nearer than the near plane gets a "no", since the rasterizer's near clip
// leaves nothing of it on screen.

#include <cstddef>
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <plx/core/core.h>
#include <plx/core/parallel.h>
#include <plx/scene/scene.h>

namespace plx::scene {

// Pixels x0 <= x < x1, y0 <= y < y1 (Conventions: (0,0) top-left, y down); covers the area
// [x0, x1] x [y0, y1] in pixel coordinates. A hole's enclosing box with inclusive pixel bounds
// (minX, minY)-(maxX, maxY) is {minX, minY, maxX + 1, maxY + 1}. Empty when x1 <= x0 or y1 <= y0.
struct PixelRect {
    int x0 = 0;
    int y0 = 0;
    int x1 = 0;
    int y1 = 0;
    bool empty() const { return x1 <= x0 || y1 <= y0; }
};

// Whether the projection of the convex hull of `points` may overlap the rectangle's area: the
// separating test of Fu, Bao, Peng between a polygon's projected enclosing box and a hole's.
// False only if every point lies nearer than the near plane, or the points' projected bounding
// box misses the rectangle by more than a rounding margin; true whenever some point lies nearer
// than the near plane and another does not. Precondition: points are finite.
bool pointsMayCoverRect(const Camera& camera, std::span<const Vec3> points, const PixelRect& rect);
// pointsMayCoverRect of a triangle's corners.
bool triangleMayCoverRect(const Camera& camera, const Vec3& a, const Vec3& b, const Vec3& c,
                          const PixelRect& rect);
// pointsMayCoverRect of a convex polygon's corners (a BSP fragment's vertices).
inline bool polygonMayCoverRect(const Camera& camera, std::span<const Vec3> corners,
                                const PixelRect& rect) {
    return pointsMayCoverRect(camera, corners, rect);
}
// pointsMayCoverRect of a box's eight corners. Precondition: the box is not empty.
bool boxMayCoverRect(const Camera& camera, const Aabb& box, const PixelRect& rect);

// The same question as pointsMayCoverRect, asked of the rectangle's frustum: the four planes
// through the eye and the rectangle's edges (widened by the rounding margin) and the near
// plane, in world space. A box or polygon wholly outside one of them cannot reach the
// rectangle. Against the projected-box test this costs a few multiply-adds per box instead of
// eight projections, and it also rejects geometry crossing the near plane that lies beside the
// rectangle (the projected test must say yes to all of it, and the boxes of large subtrees near
// the eye always cross it).
class RectFrustum {
public:
    // Preconditions: camera is the view the rectangle is in; the rectangle is not empty.
    RectFrustum(const Camera& camera, const PixelRect& rect);
    // The planes: the rectangle's four sides, then the near plane.
    static constexpr size_t kPlanes = 5;
    static constexpr size_t kSidePlanes = 4;

    // False only if the box lies wholly outside one of the first `planeCount` planes.
    // Precondition: the box is not empty.
    bool mayCoverBox(const Aabb& box, size_t planeCount = kPlanes) const {
        for (const Vec4& p : std::span(mPlanes).first(planeCount)) {
            Vec3 far(p.x >= 0.0f ? box.hi.x : box.lo.x, p.y >= 0.0f ? box.hi.y : box.lo.y,
                     p.z >= 0.0f ? box.hi.z : box.lo.z);
            if (p.x * far.x + p.y * far.y + p.z * far.z + p.w < 0.0f) return false;
        }
        return true;
    }
    // False only if every point lies outside one of the first `planeCount` planes (the convex
    // hull misses the frustum).
    bool mayCoverPoints(std::span<const Vec3> points, size_t planeCount = kPlanes) const {
        for (const Vec4& p : std::span(mPlanes).first(planeCount)) {
            bool inside = false;
            for (const Vec3& v : points) inside |= p.x * v.x + p.y * v.y + p.z * v.z + p.w >= 0.0f;
            if (!inside) return false;
        }
        return true;
    }

    // (n, d) of the planes: inside where dot(n, p) + d >= 0.
    const std::array<Vec4, kPlanes>& planes() const { return mPlanes; }

private:
    std::array<Vec4, kPlanes> mPlanes;  // (n, d): inside where dot(n, p) + d >= 0
};

// How an inner node's triangles are divided between its two children.
enum class BoxSplit {
    kMedian,       // half and half along the longest axis of their centres
    kSurfaceArea,  // the binned split of least surface area times triangle count (SAH)
};

struct BoxHierarchyConfig {
    // Most triangles per leaf bucket. Larger buckets mean fewer nodes to test per hole but more
    // triangles flagged positive with their bucket; 4 keeps false positives a few per bucket.
    int leafSize = 4;
    BoxSplit split = BoxSplit::kSurfaceArea;
};

// A node of the hierarchy. Nodes are stored depth first: an inner node's first child directly
// follows it, so a subtree is the contiguous node range [index, index + subtree size).
struct BoxNode {
    Aabb box;            // encloses every corner of the node's triangles
    uint32_t first = 0;  // leaf: first entry in BoxHierarchy::triangles(); inner: second child
    uint32_t count = 0;  // leaf: number of triangles (>= 1); inner: 0
    bool isLeaf() const { return count != 0; }
};

// Counts from one markHole query.
struct HoleQueryStats {
    size_t nodesTested = 0;        // projected boxes tested
    size_t nodesRejected = 0;      // tested and negative (their subtrees are never visited)
    size_t trianglesPositive = 0;  // triangles that may cover the rectangle
};

class BoxHierarchy;

// Per-node and per-triangle flags of the latest markHole query, reused between queries: the
// arrays are sized once, and each query clears them by bumping a generation counter.
class HoleFlags {
public:
    // Whether a triangle (scene-global index) may cover the latest query's rectangle.
    // Precondition: a query has run, and triangle < that hierarchy's triangle count.
    bool mayCover(uint32_t triangle) const {
        PLX_DCHECK(triangle < mTriangleStamp.size());
        return mTriangleStamp[triangle] == mGeneration;
    }
    // Whether a node was flagged positive (tested and not rejected) by the latest query.
    // Precondition: a query has run, and node < that hierarchy's node count.
    bool nodePositive(size_t node) const {
        PLX_DCHECK(node < mNodeStamp.size());
        return mNodeStamp[node] == mGeneration;
    }

private:
    friend class BoxHierarchy;
    // Starts a query: resizes for the hierarchy (allocating only when it changed) and moves to a
    // fresh generation, zeroing the stamps only when the 32-bit counter wraps around.
    void beginQuery(size_t nodes, size_t triangles);

    std::vector<uint32_t> mNodeStamp;
    std::vector<uint32_t> mTriangleStamp;
    uint32_t mGeneration = 0;  // stamps equal to it are positive; 0 is never a live generation
};

class BoxHierarchy {
public:
    // Builds the hierarchy over every triangle of `scene` (degenerate ones included: their box
    // is still a correct bound), iterative: nodes of more than leafSize triangles are split as
    // config.split says (a median split where surface-area bins cannot separate the centres, and
    // from depth 32 on). With a pool of two or more threads, a scene of 32k triangles or more has
    // its top three levels split on the calling thread and the subtrees below built in parallel:
    // the same hierarchy, node for node. Preconditions: `scene` is finalized, or holds no
    // triangles (empty hierarchy). Errors: kInvalidArgument for leafSize outside
    // 1..kMaxLeafSize.
    static Result<BoxHierarchy> build(const Scene& scene, const BoxHierarchyConfig& config = {},
                                      ThreadPool* pool = nullptr);

    static constexpr int kMaxLeafSize = 256;
    // Bound on maxDepth() for any scene of up to 2^32 - 1 triangles.
    static constexpr size_t kMaxDepth = 66;

    BoxHierarchy() = default;

    size_t nodeCount() const { return mNodes.size(); }
    size_t triangleCount() const { return mTriangles.size(); }
    // Precondition: index < nodeCount().
    const BoxNode& node(size_t index) const { return mNodes[index]; }
    // Scene-global triangle indices in leaf order; each leaf holds a contiguous range.
    const std::vector<uint32_t>& triangles() const { return mTriangles; }
    // Depth of the deepest leaf (root has depth 1; 0 when empty).
    size_t maxDepth() const { return mMaxDepth; }

    // Fu, Bao, Peng's per-hole flagging: tests the projected box of each node reached from the
    // root; a node missing the rectangle is rejected with its whole subtree, otherwise it is
    // flagged positive and its children are tested; triangles of positive leaves are positive.
    // Results go to *flags (previous results are cleared); stats, when given, receive the
    // counts. Visits only the nodes tested, plus the triangles of positive leaves.
    // Preconditions: camera is the view the rectangle is in; the rectangle is not empty.
    void markHole(const Camera& camera, const PixelRect& rect, HoleFlags* flags,
                  HoleQueryStats* stats = nullptr) const;
    // The same query with the frustum's plane tests (RectFrustum) in place of projected boxes:
    // flags the same triangles or fewer, never one that reaches the rectangle.
    void markHole(const RectFrustum& frustum, HoleFlags* flags,
                  HoleQueryStats* stats = nullptr) const;

private:
    template <class MayCover>
    void mark(const MayCover& mayCover, HoleFlags* flags, HoleQueryStats* stats) const;

    std::vector<BoxNode> mNodes;
    std::vector<uint32_t> mTriangles;
    size_t mMaxDepth = 0;
};

}  // namespace plx::scene
