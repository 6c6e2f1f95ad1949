// Box hierarchy and per-hole flags (Fu, Bao, Peng section 3). See <plx/scene/box_hierarchy.h>.

#include <plx/scene/box_hierarchy.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <fmt/format.h>

namespace plx::scene {

namespace {

// Slack, in pixels, added around the rectangle before declaring a miss. The projected box of a
// node's corners contains the projection of its triangles in exact arithmetic; float rounding
// of a projection is a few ulps of the pixel coordinate (under 0.01 px up to 16384 px wide), so
// 1/16 px keeps every miss a true miss while costing almost no rejections.
constexpr float kMarginPx = 1.0f / 16.0f;

// Binned surface-area splits (Wald, "On fast construction of SAH-based bounding volume
// hierarchies", 2007): 16 bins per axis over the triangle centres. From depth kSahDepthLimit on
// the build falls back to median splits, which bounds the depth by kSahDepthLimit + 33 for 2^32
// triangles whatever the geometry (BoxHierarchy::kMaxDepth); 32 bins found the same trees within
// 2% of the nodes tested on the office.
constexpr int kSahBins = 16;
constexpr uint32_t kSahDepthLimit = 32;
static_assert(kSahDepthLimit + 33 <= BoxHierarchy::kMaxDepth);

// Half the surface area of a box: proportional to the chance that a small random frustum (a
// hole's) reaches it.
float halfArea(const Aabb& box) {
    const Vec3 e = box.extent();
    return e.x * e.y + e.y * e.z + e.z * e.x;
}

// Triangles [begin, end) partitioned at the binned split of least cost
// area(left) * count(left) + area(right) * count(right); returns the first index of the second
// part, or `begin` when no bin boundary separates the centres (all in one bin).
uint32_t surfaceAreaSplit(std::vector<uint32_t>& triangles, uint32_t begin, uint32_t end,
                          const Aabb& centreBounds, const std::vector<Aabb>& boxes,
                          const std::vector<Vec3>& centres) {
    struct Bin {
        Aabb box;
        uint32_t count = 0;
    };
    const Vec3 lo = centreBounds.lo, extent = centreBounds.extent();
    auto scaleOf = [&](int axis) { return float(kSahBins) / extent[axis]; };
    auto binOf = [&](uint32_t triangle, int axis, float scale) {
        return std::min(kSahBins - 1, int((centres[triangle][axis] - lo[axis]) * scale));
    };
    float bestCost = std::numeric_limits<float>::infinity();
    int bestAxis = -1, bestBin = 0;  // the second part holds bins >= bestBin
    for (int axis = 0; axis < 3; ++axis) {
        const float scale = scaleOf(axis);  // infinite for a zero or subnormal extent
        if (!std::isfinite(scale)) continue;
        std::array<Bin, kSahBins> bins;
        for (uint32_t i = begin; i < end; ++i) {
            Bin& bin = bins[size_t(binOf(triangles[i], axis, scale))];
            bin.box.extend(boxes[triangles[i]]);
            ++bin.count;
        }
        // rightCost[b]: area * count of bins >= b.
        std::array<float, kSahBins> rightCost{};
        Aabb right;
        uint32_t rightCount = 0;
        for (int b = kSahBins - 1; b > 0; --b) {
            right.extend(bins[size_t(b)].box);
            rightCount += bins[size_t(b)].count;
            rightCost[size_t(b)] = rightCount == 0 ? 0.0f : halfArea(right) * float(rightCount);
        }
        Aabb left;
        uint32_t leftCount = 0;
        for (int b = 1; b < kSahBins; ++b) {
            left.extend(bins[size_t(b - 1)].box);
            leftCount += bins[size_t(b - 1)].count;
            if (leftCount == 0 || leftCount == end - begin) continue;
            const float cost = halfArea(left) * float(leftCount) + rightCost[size_t(b)];
            if (cost < bestCost) {
                bestCost = cost;
                bestAxis = axis;
                bestBin = b;
            }
        }
    }
    if (bestAxis < 0) return begin;
    const float scale = scaleOf(bestAxis);
    auto second = std::partition(triangles.begin() + begin, triangles.begin() + end,
                                 [&](uint32_t t) { return binOf(t, bestAxis, scale) < bestBin; });
    return uint32_t(second - triangles.begin());
}

// What every part of the build reads: the triangles' boxes and centres, and the config.
struct BuildInput {
    const std::vector<Aabb>& boxes;
    const std::vector<Vec3>& centres;
    const BoxHierarchyConfig& config;
};

// One node over triangles [begin, end): its box, and for an inner node the first index of its
// second child's triangles (the range partitioned); a leaf has its `first` and `count` set.
struct NodeSplit {
    BoxNode node;
    uint32_t mid = 0;
};

NodeSplit splitNode(const BuildInput& in, uint32_t begin, uint32_t end, uint32_t depth,
                    std::vector<uint32_t>* triangles) {
    NodeSplit out;
    Aabb centreBounds;
    for (uint32_t i = begin; i < end; ++i) {
        out.node.box.extend(in.boxes[(*triangles)[i]]);
        centreBounds.extend(in.centres[(*triangles)[i]]);
    }
    const uint32_t size = end - begin;
    if (size <= uint32_t(in.config.leafSize)) {
        out.node.first = begin;
        out.node.count = size;
        return out;
    }
    out.mid = begin;
    if (in.config.split == BoxSplit::kSurfaceArea && depth < kSahDepthLimit)
        out.mid = surfaceAreaSplit(*triangles, begin, end, centreBounds, in.boxes, in.centres);
    if (out.mid == begin) {  // median split on the centres' longest axis
        Vec3 extent = centreBounds.extent();
        int axis =
            extent.x >= extent.y && extent.x >= extent.z ? 0 : (extent.y >= extent.z ? 1 : 2);
        out.mid = begin + size / 2;
        std::nth_element(
            triangles->begin() + begin, triangles->begin() + out.mid, triangles->begin() + end,
            [&](uint32_t a, uint32_t b) { return in.centres[a][axis] < in.centres[b][axis]; });
    }
    return out;
}

// Task of the iterative build: triangles [begin, end) become a subtree.
struct BuildTask {
    uint32_t begin;
    uint32_t end;
    int64_t parentOfSecondChild;  // node whose `first` must point here, or -1
    uint32_t depth;
};

// The subtree over triangles [begin, end), its root at `depth`, appended to *nodes depth first,
// first child before second (popping the first child right after its parent puts it at index
// parent + 1). Inner nodes' `first` index *nodes. Returns the deepest leaf's depth.
size_t buildSubtree(const BuildInput& in, uint32_t begin, uint32_t end, uint32_t depth,
                    std::vector<uint32_t>* triangles, std::vector<BoxNode>* nodes) {
    size_t maxDepth = 0;
    std::vector<BuildTask> stack{{begin, end, -1, depth}};
    while (!stack.empty()) {
        BuildTask task = stack.back();
        stack.pop_back();
        const uint32_t index = uint32_t(nodes->size());
        if (task.parentOfSecondChild >= 0) (*nodes)[size_t(task.parentOfSecondChild)].first = index;
        maxDepth = std::max<size_t>(maxDepth, task.depth);
        const NodeSplit split = splitNode(in, task.begin, task.end, task.depth, triangles);
        nodes->push_back(split.node);
        if (split.node.isLeaf()) continue;
        stack.push_back({split.mid, task.end, int64_t(index), task.depth + 1});
        stack.push_back({task.begin, split.mid, -1, task.depth + 1});
    }
    return maxDepth;
}

// Below this many triangles the build stays on the calling thread.
constexpr size_t kParallelBuildMin = 1 << 15;
// Levels split on the calling thread before the subtrees below go to the pool: up to eight
// subtrees, enough to balance uneven splits over two to four threads.
constexpr int kSerialTopLevels = 3;

// The top levels of the hierarchy, split on the calling thread; a Top either holds one of their
// nodes or stands for a subtree built in parallel.
struct Top {
    BoxNode node;
    int firstChild = -1, secondChild = -1;  // Top indices, for an inner node
    int subtree = -1;                       // index of its ParallelSubtree, or -1
};

struct ParallelSubtree {
    uint32_t begin, end, depth;
    std::vector<BoxNode> nodes;  // inner nodes' `first` index this vector
    size_t maxDepth = 0;
};

int splitTop(const BuildInput& in, uint32_t begin, uint32_t end, uint32_t depth, int level,
             std::vector<uint32_t>* triangles, std::vector<Top>* tops,
             std::vector<ParallelSubtree>* subtrees, size_t* maxDepth) {
    const int index = int(tops->size());
    tops->push_back({});
    if (level == kSerialTopLevels) {
        (*tops)[size_t(index)].subtree = int(subtrees->size());
        subtrees->push_back({begin, end, depth, {}, 0});
        return index;
    }
    *maxDepth = std::max<size_t>(*maxDepth, depth);
    const NodeSplit split = splitNode(in, begin, end, depth, triangles);
    (*tops)[size_t(index)].node = split.node;
    if (split.node.isLeaf()) return index;
    const int first =
        splitTop(in, begin, split.mid, depth + 1, level + 1, triangles, tops, subtrees, maxDepth);
    const int second =
        splitTop(in, split.mid, end, depth + 1, level + 1, triangles, tops, subtrees, maxDepth);
    (*tops)[size_t(index)].firstChild = first;
    (*tops)[size_t(index)].secondChild = second;
    return index;
}

// Appends Top `index` and everything below it to *nodes in buildSubtree's order.
void appendTop(const std::vector<Top>& tops, const std::vector<ParallelSubtree>& subtrees,
               int index, std::vector<BoxNode>* nodes) {
    const Top& top = tops[size_t(index)];
    if (top.subtree >= 0) {
        const uint32_t offset = uint32_t(nodes->size());
        for (BoxNode node : subtrees[size_t(top.subtree)].nodes) {
            if (!node.isLeaf()) node.first += offset;
            nodes->push_back(node);
        }
        return;
    }
    const size_t at = nodes->size();
    nodes->push_back(top.node);
    if (top.node.isLeaf()) return;
    appendTop(tops, subtrees, top.firstChild, nodes);
    (*nodes)[at].first = uint32_t(nodes->size());
    appendTop(tops, subtrees, top.secondChild, nodes);
}

// buildSubtree over all `count` triangles with the subtrees below the top levels built on the
// pool: the same nodes in the same order (disjoint triangle ranges, the same splits).
void buildInParallel(const BuildInput& in, uint32_t count, ThreadPool& pool,
                     std::vector<uint32_t>* triangles, std::vector<BoxNode>* nodes,
                     size_t* maxDepth) {
    std::vector<Top> tops;
    std::vector<ParallelSubtree> subtrees;
    *maxDepth = 0;
    splitTop(in, 0, count, 1, 0, triangles, &tops, &subtrees, maxDepth);
    pool.parallelFor(subtrees.size(), 1, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
            ParallelSubtree& s = subtrees[i];
            s.maxDepth = buildSubtree(in, s.begin, s.end, s.depth, triangles, &s.nodes);
        }
    });
    for (const ParallelSubtree& s : subtrees) *maxDepth = std::max(*maxDepth, s.maxDepth);
    appendTop(tops, subtrees, 0, nodes);
}

}  // namespace

bool pointsMayCoverRect(const Camera& camera, std::span<const Vec3> points, const PixelRect& rect) {
    const Mat4& clipFromWorld = camera.clipFromWorld();
    float nearPlane = camera.desc().nearPlane;
    size_t nearer = 0;
    float minX = std::numeric_limits<float>::infinity(), minY = minX;
    float maxX = -minX, maxY = -minX;
    for (const Vec3& p : points) {
        Vec4 clip = clipFromWorld * Vec4(p, 1.0f);
        // clip.w is the view-space distance along the viewing direction (OpenGL projection).
        if (clip.w < nearPlane) {
            ++nearer;
            continue;
        }
        Vec2 pixel = camera.pixelFromClip(clip);
        minX = std::min(minX, pixel.x);
        maxX = std::max(maxX, pixel.x);
        minY = std::min(minY, pixel.y);
        maxY = std::max(maxY, pixel.y);
    }
    if (nearer == points.size()) return false;  // wholly clipped by the near plane
    if (nearer > 0) return true;  // the visible part's projection is unbounded: conservative
    return !(maxX < float(rect.x0) - kMarginPx || minX > float(rect.x1) + kMarginPx ||
             maxY < float(rect.y0) - kMarginPx || minY > float(rect.y1) + kMarginPx);
}

bool triangleMayCoverRect(const Camera& camera, const Vec3& a, const Vec3& b, const Vec3& c,
                          const PixelRect& rect) {
    const Vec3 corners[3] = {a, b, c};
    return pointsMayCoverRect(camera, corners, rect);
}

bool boxMayCoverRect(const Camera& camera, const Aabb& box, const PixelRect& rect) {
    PLX_DCHECK(!box.isEmpty());
    std::array<Vec3, 8> corners;
    for (int i = 0; i < 8; ++i)
        corners[size_t(i)] = Vec3((i & 1) ? box.hi.x : box.lo.x, (i & 2) ? box.hi.y : box.lo.y,
                                  (i & 4) ? box.hi.z : box.lo.z);
    return pointsMayCoverRect(camera, corners, rect);
}

void HoleFlags::beginQuery(size_t nodes, size_t triangles) {
    if (mNodeStamp.size() != nodes || mTriangleStamp.size() != triangles) {
        mNodeStamp.assign(nodes, 0);
        mTriangleStamp.assign(triangles, 0);
        mGeneration = 0;
    }
    if (++mGeneration == 0) {
        // After 2^32 - 1 queries: old stamps could alias the new generation.
        std::fill(mNodeStamp.begin(), mNodeStamp.end(), 0u);
        std::fill(mTriangleStamp.begin(), mTriangleStamp.end(), 0u);
        mGeneration = 1;
    }
}

Result<BoxHierarchy> BoxHierarchy::build(const Scene& scene, const BoxHierarchyConfig& config,
                                         ThreadPool* pool) {
    if (config.leafSize < 1 || config.leafSize > kMaxLeafSize)
        return errorStatus(
            ErrorCode::kInvalidArgument,
            fmt::format("box hierarchy leafSize {} outside 1..{}", config.leafSize, kMaxLeafSize));
    BoxHierarchy h;
    size_t count = scene.triangleCount();
    if (count == 0) return h;
    if (count > size_t(std::numeric_limits<uint32_t>::max()))
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("box hierarchy of {} triangles: at most 2^32 - 1", count));

    // Per triangle: its box and the centre the splits sort by.
    std::vector<Aabb> boxes(count);
    std::vector<Vec3> centres(count);
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
        const Mesh& mesh = scene.meshes[m];
        for (size_t t = 0; t < mesh.triangleCount(); ++t) {
            size_t global = scene.firstTriangle(m) + t;
            Aabb& box = boxes[global];
            for (int k = 0; k < 3; ++k) box.extend(mesh.positions[mesh.indices[3 * t + size_t(k)]]);
            centres[global] = box.center();
        }
    }
    h.mTriangles.resize(count);
    for (size_t i = 0; i < count; ++i) h.mTriangles[i] = uint32_t(i);
    h.mNodes.reserve(2 * (count / size_t(config.leafSize)) + 1);
    const BuildInput input{boxes, centres, config};
    if (pool && pool->threadCount() > 1 && count >= kParallelBuildMin) {
        buildInParallel(input, uint32_t(count), *pool, &h.mTriangles, &h.mNodes, &h.mMaxDepth);
    } else {
        h.mMaxDepth = buildSubtree(input, 0, uint32_t(count), 1, &h.mTriangles, &h.mNodes);
    }
    return h;
}

RectFrustum::RectFrustum(const Camera& camera, const PixelRect& rect) {
    PLX_CHECK(!rect.empty());
    // Camera::pixelFromClip: pixel x = (clip.x / w + 1) W / 2, pixel y = (1 - clip.y / w) H / 2.
    // For w > 0, x >= X0 is clip.x - (2 X0 / W - 1) w >= 0, and so on; the near plane's
    // w >= near makes w > 0 hold everywhere inside.
    const Mat4& m = camera.clipFromWorld();
    auto row = [&m](int i) { return Vec4(m[0][i], m[1][i], m[2][i], m[3][i]); };
    const Vec4 rowX = row(0), rowY = row(1), rowW = row(3);
    const float w = float(camera.width()), h = float(camera.height());
    const float ax0 = 2.0f * (float(rect.x0) - kMarginPx) / w - 1.0f;
    const float ax1 = 2.0f * (float(rect.x1) + kMarginPx) / w - 1.0f;
    const float by0 = 1.0f - 2.0f * (float(rect.y0) - kMarginPx) / h;
    const float by1 = 1.0f - 2.0f * (float(rect.y1) + kMarginPx) / h;
    mPlanes = {{rowX - ax0 * rowW, ax1 * rowW - rowX, by0 * rowW - rowY, rowY - by1 * rowW,
                rowW - Vec4(0.0f, 0.0f, 0.0f, camera.desc().nearPlane)}};
}

void BoxHierarchy::markHole(const Camera& camera, const PixelRect& rect, HoleFlags* flags,
                            HoleQueryStats* stats) const {
    PLX_CHECK(!rect.empty());
    mark([&](const Aabb& box) { return boxMayCoverRect(camera, box, rect); }, flags, stats);
}

void BoxHierarchy::markHole(const RectFrustum& frustum, HoleFlags* flags,
                            HoleQueryStats* stats) const {
    mark([&](const Aabb& box) { return frustum.mayCoverBox(box); }, flags, stats);
}

template <class MayCover>
void BoxHierarchy::mark(const MayCover& mayCover, HoleFlags* flags, HoleQueryStats* stats) const {
    flags->beginQuery(mNodes.size(), mTriangles.size());
    uint32_t generation = flags->mGeneration;
    HoleQueryStats counts;
    if (!mNodes.empty()) {
        // The stack holds at most one pending second child per level.
        std::array<uint32_t, kMaxDepth> stack;
        size_t top = 0;
        stack[top++] = 0;
        while (top > 0) {
            uint32_t index = stack[--top];
            const BoxNode& node = mNodes[index];
            ++counts.nodesTested;
            if (!mayCover(node.box)) {
                ++counts.nodesRejected;  // negative with its subtree: left unstamped
                continue;
            }
            flags->mNodeStamp[index] = generation;
            if (node.isLeaf()) {
                for (uint32_t i = node.first; i < node.first + node.count; ++i)
                    flags->mTriangleStamp[mTriangles[i]] = generation;
                counts.trianglesPositive += node.count;
                continue;
            }
            PLX_DCHECK(top + 2 <= stack.size());
            stack[top++] = node.first;  // second child
            stack[top++] = index + 1;   // first child
        }
    }
    if (stats) *stats = counts;
}

}  // namespace plx::scene
