#pragma once
// BSP tree of a whole scene (Fuchs, Kedem, Naylor, "On Visible Surface Generation by A Priori
// Tree Structures", SIGGRAPH 1980), built once and reused from any viewpoint. Fu, Bao, Peng
// (section 3) walk it front to back to find, for each disocclusion hole, the polygons lying
// behind the polygons that surround the hole.
//
// Each node holds a splitting plane and the convex polygons (fragments) lying in it. Triangles
// straddling a plane are cut into convex fragments; every fragment remembers its source
// triangle's scene-global index (the polygon-ID convention of <plx/scene/scene.h>), so a walk
// can look up per-triangle data (ID buffer values, box-hierarchy flags) for any fragment.
//
// Limits: the order is exact for polygons that do not interpenetrate beyond the coplanarity
// epsilon; a point within epsilon of a splitting plane may be ordered on either side of it.

#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>
#include <vector>

#include <plx/core/core.h>
#include <plx/scene/scene.h>

namespace plx::scene {

struct BspConfig {
    // Splitting-plane candidates tried per node: the planes of this many polygons drawn at
    // random from the node's list. More candidates find planes that cut fewer polygons but cost
    // build time linearly; 12 keeps the build of 1M triangles to about a second.
    int candidatePlanes = 12;
    // Each candidate is scored against at most this many polygons of the node, drawn at random,
    // so choosing a plane costs O(candidatePlanes * scoreSample) however large the node is.
    int scoreSample = 128;
    // Score of a candidate = splitWeight * splits + |front - back| over the sample (lower is
    // better). A split adds a fragment for good (memory, traversal time) while imbalance only
    // deepens the tree, which the iterative build and walk tolerate, so splits weigh heavily.
    float splitWeight = 8.0f;
    // Coplanarity epsilon relative to the scene's size (largest absolute coordinate plus the
    // bounds' diagonal): points closer to a plane than this count as lying in it. It must exceed
    // float rounding of plane distances (a few ulps of the coordinates, ~1e-7 relative) and stay
    // below the thinnest gap between surfaces that must be ordered (2e-6 of 100 m is 0.2 mm).
    float coplanarEpsilon = 2e-6f;
    // Build fails with kOutOfRange once fragments exceed this many per source triangle: a bound
    // on memory for adversarial inputs where every plane cuts every other polygon.
    float maxFragmentsPerTriangle = 16.0f;
    // Seed of the candidate and sample draws; the same seed builds the same tree.
    uint64_t seed = 1;
};

// A convex polygon lying in its node's plane: a whole source triangle or a piece of one.
struct BspFragment {
    uint32_t sourceTriangle = 0;  // scene-global triangle index
    uint32_t firstVertex = 0;     // into BspTree::vertices()
    uint32_t vertexCount = 0;     // >= 3, counter-clockwise as the source triangle
};

// An interior node of the tree. Children are node indices, or kNoNode.
struct BspNode {
    Vec4 plane{0.0f};            // (n, d): unit normal n, signed distance of p is dot(n, p) + d
    uint32_t firstFragment = 0;  // the fragments in this plane: [first, first + count)
    uint32_t fragmentCount = 0;
    int32_t front = -1;   // subtree on the side n points to
    int32_t back = -1;    // subtree on the other side
    int32_t parent = -1;  // kNoNode for the root; lets the walks run without a stack
};

struct BspStats {
    size_t sourceTriangles = 0;    // the scene's triangle count
    size_t degenerateSkipped = 0;  // triangles with no well-defined plane, not in the tree
    size_t fragments = 0;          // polygons stored in the nodes
    size_t splitTriangles = 0;     // source triangles cut into more than one fragment
    size_t nodes = 0;
    size_t maxDepth = 0;     // root has depth 1; 0 for an empty tree
    size_t vertexCount = 0;  // fragment vertices stored
    size_t memoryBytes = 0;  // nodes, subtree boxes, fragments and vertices
    // Fragments per tree triangle (sourceTriangles - degenerateSkipped); 0 for an empty tree.
    double fragmentsPerTriangle() const;
};

class BspTree {
public:
    static constexpr int32_t kNoNode = -1;

    // Builds the tree of every triangle of `scene`, skipping degenerate ones. Iterative, so
    // degenerate inputs (a chain of parallel planes) cannot exhaust the stack. Preconditions:
    // `scene` is finalized, or holds no triangles (which gives an empty tree). Errors:
    // kInvalidArgument for a config out of range (counts < 1, negative weight or epsilon,
    // fragment bound < 1), kOutOfRange when the fragment bound is exceeded.
    static Result<BspTree> build(const Scene& scene, const BspConfig& config = {});

    BspTree() = default;

    const BspStats& stats() const { return mStats; }
    bool empty() const { return mNodes.empty(); }
    size_t fragmentCount() const { return mFragments.size(); }
    size_t nodeCount() const { return mNodes.size(); }
    // Index of the root node, or kNoNode for an empty tree.
    int32_t root() const { return mNodes.empty() ? kNoNode : 0; }
    // Absolute coplanarity epsilon the tree was built with (scene units).
    float epsilon() const { return mEpsilon; }

    // Precondition: index < nodeCount().
    const BspNode& node(size_t index) const { return mNodes[index]; }
    // Precondition: index < fragmentCount().
    const BspFragment& fragment(size_t index) const { return mFragments[index]; }
    // The corners of a fragment. Precondition: index < fragmentCount().
    std::span<const Vec3> fragmentVertices(size_t index) const {
        const BspFragment& f = mFragments[index];
        return {mVertices.data() + f.firstVertex, f.vertexCount};
    }
    // Plane (n, d) of the node holding a fragment. Precondition: index < fragmentCount().
    const Vec4& fragmentPlane(size_t index) const { return mNodes[mFragmentNode[index]].plane; }
    const std::vector<Vec3>& vertices() const { return mVertices; }
    // Box enclosing every fragment vertex of the node's subtree (the node included): what a walk
    // may test to skip the whole subtree. Precondition: index < nodeCount().
    const Aabb& subtreeBox(size_t index) const { return mSubtreeBoxes[index]; }

    // Calls fn(fragmentIndex) for every fragment, nearest first as seen from eyePos: the
    // modified in-order walk of Fuchs-Kedem-Naylor (near subtree, node's plane, far subtree) in
    // O(nodes + fragments), without allocating. If fn returns bool, false stops the walk. A
    // fragment is never hidden by one that comes after it. Fragments in one plane come in
    // storage order, and the order is the same for every eyePos within one cell of the tree.
    template <class Fn>
    void forEachFrontToBack(const Vec3& eyePos, Fn&& fn) const {
        walk<true>(eyePos, fn);
    }
    // As forEachFrontToBack, farthest first (the painter's order).
    template <class Fn>
    void forEachBackToFront(const Vec3& eyePos, Fn&& fn) const {
        walk<false>(eyePos, fn);
    }
    // forEachFrontToBack restricted to the subtrees `accept` admits: on reaching a node from its
    // parent the walk calls accept(nodeIndex, subtreeBox(nodeIndex)) (int32_t, const Aabb&) and,
    // when it returns false, skips the node and its whole subtree, fragments included. The
    // fragments emitted are those of the plain walk whose node and every ancestor are accepted,
    // in the plain walk's order; fn returning false stops the walk as there. Stack-free like the
    // plain walk. Returns the nodes reached (accept's calls).
    template <class Accept, class Fn>
    size_t forEachFrontToBackPruned(const Vec3& eyePos, Accept&& accept, Fn&& fn) const {
        return walk<true>(eyePos, fn, accept);
    }
    // Writes every fragment index, nearest first, into *order (resized; its capacity is reused).
    void frontToBack(const Vec3& eyePos, std::vector<uint32_t>* order) const;

private:
    static bool acceptAll(int32_t, const Aabb&) { return true; }
    template <bool kFrontToBack, class Fn, class Accept = decltype(acceptAll)>
    size_t walk(const Vec3& eyePos, Fn& fn, Accept& accept = acceptAll) const;

    std::vector<BspNode> mNodes;
    std::vector<BspFragment> mFragments;
    std::vector<uint32_t> mFragmentNode;  // node holding each fragment
    std::vector<Vec3> mVertices;
    std::vector<Aabb> mSubtreeBoxes;  // per node
    BspStats mStats;
    float mEpsilon = 0.0f;

    friend class BspBuilder;
};

// Signed distance of p from plane (n, d): positive on the side n points to.
inline float planeDistance(const Vec4& plane, const Vec3& p) {
    return plane.x * p.x + plane.y * p.y + plane.z * p.z + plane.w;
}

template <bool kFrontToBack, class Fn, class Accept>
size_t BspTree::walk(const Vec3& eyePos, Fn& fn, Accept& accept) const {
    // In-order walk with parent links instead of a stack: arriving at a node from its parent we
    // descend to the near child; returning from the near child we emit the node's fragments and
    // descend to the far child; returning from the far child we climb. "Near" is the child on
    // the eye's side of the plane (the far one when walking back to front). A node `accept`
    // rejects on arrival is left at once, as if its subtree had been walked: back at the parent
    // it reads as a return from that child.
    auto emit = [&](const BspNode& n) {
        for (uint32_t i = n.firstFragment; i < n.firstFragment + n.fragmentCount; ++i) {
            if constexpr (std::is_same_v<std::invoke_result_t<Fn&, uint32_t>, bool>) {
                if (!fn(i)) return false;
            } else {
                fn(i);
            }
        }
        return true;
    };
    size_t reached = 0;
    int32_t current = root();
    int32_t previous = kNoNode;
    while (current != kNoNode) {
        const BspNode& n = mNodes[size_t(current)];
        if (previous == n.parent) {
            ++reached;
            if (!accept(current, mSubtreeBoxes[size_t(current)])) {
                previous = current;
                current = n.parent;
                continue;
            }
        }
        bool eyeInFront = planeDistance(n.plane, eyePos) >= 0.0f;
        int32_t nearChild = (eyeInFront == kFrontToBack) ? n.front : n.back;
        int32_t farChild = (eyeInFront == kFrontToBack) ? n.back : n.front;
        int32_t next;
        if (previous == n.parent) {
            if (nearChild != kNoNode) {
                next = nearChild;
            } else {
                if (!emit(n)) return reached;
                next = farChild != kNoNode ? farChild : n.parent;
            }
        } else if (previous == nearChild) {
            if (!emit(n)) return reached;
            next = farChild != kNoNode ? farChild : n.parent;
        } else {
            next = n.parent;
        }
        previous = current;
        current = next;
    }
    return reached;
}

}  // namespace plx::scene
