// Cells: the scene's rooms, or a kd subdivision of its bounds by triangle count
// (docs/stream-format.md, "Which cell a point or polygon belongs to").

#include <plx/stream/cells.h>

#include <algorithm>
#include <queue>

#include <fmt/format.h>

namespace plx::stream {
namespace {

bool boxHolds(const Aabb& box, const Vec3& p) {
    return p.x >= box.lo.x && p.x <= box.hi.x && p.y >= box.lo.y && p.y <= box.hi.y &&
           p.z >= box.lo.z && p.z <= box.hi.z;
}

float boxDistance2(const Aabb& box, const Vec3& p) {
    Vec3 d = glm::max(glm::max(box.lo - p, p - box.hi), Vec3(0.0f));
    return glm::dot(d, d);
}

// One node of the kd tree: its box and the triangles whose centroids it holds; a split node
// has two children (low side first).
struct KdNode {
    Aabb box;
    std::vector<uint32_t> triangles;
    int low = -1, high = -1;
};

int longestAxis(const Vec3& extent) {
    if (extent.x >= extent.y && extent.x >= extent.z) return 0;
    return extent.y >= extent.z ? 1 : 2;
}

// Splits node `n` at the median centroid along its box's longest side; false when the rule
// says it stays a leaf (small, short or a split that would leave one side empty).
bool splitKdNode(std::vector<KdNode>& nodes, size_t n, const std::vector<Vec3>& centroids,
                 const CellConfig& config, float minSide) {
    KdNode& node = nodes[n];
    if (node.triangles.size() <= size_t(config.maxTrianglesPerCell)) return false;
    const int axis = longestAxis(node.box.extent());
    if (node.box.extent()[axis] < minSide) return false;
    std::vector<uint32_t> sorted = node.triangles;
    auto mid = sorted.begin() + std::ptrdiff_t(sorted.size() / 2);
    auto less = [&](uint32_t a, uint32_t b) {
        float ca = centroids[a][axis], cb = centroids[b][axis];
        return ca < cb || (ca == cb && a < b);
    };
    std::nth_element(sorted.begin(), mid, sorted.end(), less);
    const float split = centroids[*mid][axis];
    KdNode low, high;
    low.box = high.box = node.box;
    low.box.hi[axis] = high.box.lo[axis] = split;
    // Points on the split plane go low, as cellOfPoint gives them the lower-index leaf.
    for (uint32_t t : node.triangles)
        (centroids[t][axis] <= split ? low : high).triangles.push_back(t);
    if (low.triangles.empty() || high.triangles.empty()) return false;
    node.triangles.clear();
    node.low = int(nodes.size());
    node.high = node.low + 1;
    nodes.push_back(std::move(low));
    nodes.push_back(std::move(high));
    return true;
}

// Leaves in depth-first order, low side first: the cells' numbering.
void collectLeaves(const std::vector<KdNode>& nodes, int n, std::vector<int>* leaves) {
    if (nodes[size_t(n)].low < 0) {
        leaves->push_back(n);
        return;
    }
    collectLeaves(nodes, nodes[size_t(n)].low, leaves);
    collectLeaves(nodes, nodes[size_t(n)].high, leaves);
}

Status checkConfig(const CellConfig& config) {
    if (config.maxTrianglesPerCell < 1 || config.maxKdCells < 1 || config.maxKdCells > kMaxCells ||
        !(config.minSideFraction >= 0.0f))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("cell config out of range: max triangles {} (>= 1), max "
                                       "cells {} (1..{})",
                                       config.maxTrianglesPerCell, config.maxKdCells, kMaxCells));
    return Status::ok();
}

}  // namespace

Vec3 triangleCentroid(const scene::Scene& scene, uint32_t triangle) {
    const size_t m = scene.meshOfTriangle(triangle);
    const scene::Mesh& mesh = scene.meshes[m];
    const size_t t = triangle - scene.firstTriangle(m);
    return (mesh.positions[mesh.indices[3 * t]] + mesh.positions[mesh.indices[3 * t + 1]] +
            mesh.positions[mesh.indices[3 * t + 2]]) /
           3.0f;
}

uint32_t cellOfPoint(const std::vector<Aabb>& boxes, const Vec3& pos) {
    PLX_CHECK(!boxes.empty());
    for (size_t i = 0; i < boxes.size(); ++i)
        if (boxHolds(boxes[i], pos)) return uint32_t(i);
    size_t best = 0;
    float bestD = boxDistance2(boxes[0], pos);
    for (size_t i = 1; i < boxes.size(); ++i) {
        float d = boxDistance2(boxes[i], pos);
        if (d < bestD) best = i, bestD = d;
    }
    return uint32_t(best);
}

// Sweep and prune along x: the boxes sorted by their low x, each tested only against those that
// start before it ends (O(n log n + pairs) where all-pairs took 2.1 s for 30,000 boxes).
std::vector<std::vector<uint32_t>> adjacentCells(const std::vector<Aabb>& boxes, float tolerance) {
    std::vector<uint32_t> byLowX(boxes.size());
    for (uint32_t i = 0; i < uint32_t(boxes.size()); ++i) byLowX[i] = i;
    std::sort(byLowX.begin(), byLowX.end(),
              [&](uint32_t a, uint32_t b) { return boxes[a].lo.x < boxes[b].lo.x; });
    std::vector<std::vector<uint32_t>> adjacent(boxes.size());
    for (size_t s = 0; s < byLowX.size(); ++s) {
        const Aabb& a = boxes[byLowX[s]];
        for (size_t r = s + 1; r < byLowX.size(); ++r) {
            const Aabb& b = boxes[byLowX[r]];
            if (b.lo.x > a.hi.x + tolerance) break;  // so do all later ones
            bool touch = true;
            for (int k = 0; k < 3; ++k)
                touch = touch && a.lo[k] <= b.hi[k] + tolerance && b.lo[k] <= a.hi[k] + tolerance;
            if (!touch) continue;
            adjacent[byLowX[s]].push_back(byLowX[r]);
            adjacent[byLowX[r]].push_back(byLowX[s]);
        }
    }
    for (auto& cells : adjacent) std::sort(cells.begin(), cells.end());
    return adjacent;
}

Result<Cells> kdCells(const scene::Scene& scene, const CellConfig& config) {
    PLX_RETURN_IF_ERROR(checkConfig(config));
    const uint32_t triangles = uint32_t(scene.triangleCount());
    std::vector<Vec3> centroids(triangles);
    for (uint32_t t = 0; t < triangles; ++t) centroids[t] = triangleCentroid(scene, t);
    std::vector<KdNode> nodes(1);
    nodes[0].box = scene.bounds();
    nodes[0].triangles.resize(triangles);
    for (uint32_t t = 0; t < triangles; ++t) nodes[0].triangles[t] = t;
    const float minSide = config.minSideFraction * scene.bounds().diagonal();
    // Split the fullest leaf first (ties: the earliest node), so the cell limit cuts the
    // densest regions last rather than whichever side a depth-first order reaches first.
    auto fuller = [&](size_t a, size_t b) {
        size_t na = nodes[a].triangles.size(), nb = nodes[b].triangles.size();
        return na < nb || (na == nb && a > b);
    };
    std::priority_queue<size_t, std::vector<size_t>, decltype(fuller)> open(fuller);
    open.push(0);
    int leaves = 1;
    while (!open.empty() && leaves < config.maxKdCells) {
        size_t n = open.top();
        open.pop();
        if (!splitKdNode(nodes, n, centroids, config, minSide)) continue;
        ++leaves;
        open.push(size_t(nodes[n].low));
        open.push(size_t(nodes[n].high));
    }
    std::vector<int> order;
    collectLeaves(nodes, 0, &order);
    Cells cells;
    cells.cellOfTriangle.resize(triangles);
    for (size_t c = 0; c < order.size(); ++c) {
        const KdNode& leaf = nodes[size_t(order[c])];
        cells.boxes.push_back(leaf.box);
        for (uint32_t t : leaf.triangles) cells.cellOfTriangle[t] = uint32_t(c);
    }
    return cells;
}

Result<Cells> makeCells(const scene::Scene& scene, const CellConfig& config) {
    if (scene.rooms.empty()) return kdCells(scene, config);
    PLX_RETURN_IF_ERROR(checkConfig(config));
    if (scene.rooms.size() > size_t(kMaxCells))
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("{} rooms, more than the {} cells a database holds",
                                       scene.rooms.size(), kMaxCells));
    Cells cells;
    cells.fromRooms = true;
    cells.boxes = scene.rooms;
    cells.cellOfTriangle.resize(scene.triangleCount());
    for (uint32_t t = 0; t < uint32_t(scene.triangleCount()); ++t)
        cells.cellOfTriangle[t] = cellOfPoint(cells.boxes, triangleCentroid(scene, t));
    return cells;
}

}  // namespace plx::stream
