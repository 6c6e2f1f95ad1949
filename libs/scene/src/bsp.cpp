// BSP tree construction (Fuchs, Kedem, Naylor 1980), as Fu, Bao, Peng section 3 use it to order a
// scene's polygons from any viewpoint. See <plx/scene/bsp.h> for the structure and its limits.

#include <plx/scene/bsp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <fmt/format.h>

namespace plx::scene {

double BspStats::fragmentsPerTriangle() const {
    size_t inTree = sourceTriangles - degenerateSkipped;
    return inTree == 0 ? 0.0 : double(fragments) / double(inTree);
}

void BspTree::frontToBack(const Vec3& eyePos, std::vector<uint32_t>* order) const {
    order->clear();
    order->reserve(mFragments.size());
    forEachFrontToBack(eyePos, [&](uint32_t f) { order->push_back(f); });
}

namespace {

// A convex polygon still waiting for its node: vertices in the builder's pool.
struct WorkPolygon {
    uint32_t source;
    uint32_t firstVertex;
    uint32_t vertexCount;
};

// A subtree to build: the polygons in its half-space and where to hang it.
struct Task {
    int32_t parent;
    bool isFront;  // hangs on the parent's front side
    uint32_t depth;
    std::vector<uint32_t> polygons;
};

enum class Side { kCoplanar, kFront, kBack, kStraddle };

// SplitMix64: small, fast and good enough to draw candidate and sample indices reproducibly.
uint64_t nextRandom(uint64_t* state) {
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

// Plane (unit n, d) of a triangle computed in double, so that even a sliver's corners lie within
// float rounding of it; false when the triangle has no well-defined plane (its doubled area is
// below 1e-12 of its longest edge squared: collinear or repeated corners up to rounding).
bool trianglePlane(const Vec3& a, const Vec3& b, const Vec3& c, Vec4* plane) {
    double e1[3] = {double(b.x) - a.x, double(b.y) - a.y, double(b.z) - a.z};
    double e2[3] = {double(c.x) - a.x, double(c.y) - a.y, double(c.z) - a.z};
    double e3[3] = {double(c.x) - b.x, double(c.y) - b.y, double(c.z) - b.z};
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                   e1[0] * e2[1] - e1[1] * e2[0]};
    double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    auto sq = [](const double* e) { return e[0] * e[0] + e[1] * e[1] + e[2] * e[2]; };
    double longest = std::max({sq(e1), sq(e2), sq(e3)});
    if (!(len > 1e-12 * longest)) return false;
    for (double& x : n) x /= len;
    double cx = (double(a.x) + b.x + c.x) / 3.0;
    double cy = (double(a.y) + b.y + c.y) / 3.0;
    double cz = (double(a.z) + b.z + c.z) / 3.0;
    *plane =
        Vec4(float(n[0]), float(n[1]), float(n[2]), float(-(n[0] * cx + n[1] * cy + n[2] * cz)));
    return true;
}

}  // namespace

// Builds a BspTree; a class so that BspTree can befriend it and keep its arrays private.
class BspBuilder {
public:
    BspBuilder(const BspConfig& config, float epsilon)
        : mConfig(config), mEpsilon(epsilon), mRandom(config.seed) {}

    Result<BspTree> run(const Scene& scene) {
        BspTree tree;
        tree.mEpsilon = mEpsilon;
        tree.mStats.sourceTriangles = scene.triangleCount();
        std::vector<uint32_t> all = collectTriangles(scene, &tree.mStats.degenerateSkipped);
        size_t inTree = all.size();
        // Fragments alive (stored or pending) never exceed this; each split adds one.
        double bound = double(mConfig.maxFragmentsPerTriangle) * double(inTree);
        size_t alive = inTree;

        std::vector<Task> stack;
        if (!all.empty()) stack.push_back({BspTree::kNoNode, true, 1, std::move(all)});
        std::vector<uint32_t> coplanar;
        while (!stack.empty()) {
            Task task = std::move(stack.back());
            stack.pop_back();
            int32_t nodeIndex = int32_t(tree.mNodes.size());
            if (task.parent != BspTree::kNoNode) {
                BspNode& parent = tree.mNodes[size_t(task.parent)];
                (task.isFront ? parent.front : parent.back) = nodeIndex;
            }
            tree.mStats.maxDepth = std::max<size_t>(tree.mStats.maxDepth, task.depth);

            uint32_t splitter = chooseSplitter(task.polygons);
            Vec4 plane = mPlanes[mPolygons[splitter].source];
            Task front{nodeIndex, true, task.depth + 1, {}};
            Task back{nodeIndex, false, task.depth + 1, {}};
            coplanar.clear();
            for (uint32_t p : task.polygons) {
                // The splitter lies in its own plane by definition, whatever rounding says, so
                // every node takes at least one polygon and the build terminates.
                Side side = p == splitter ? Side::kCoplanar : classify(plane, mPolygons[p]);
                switch (side) {
                    case Side::kCoplanar:
                        coplanar.push_back(p);
                        break;
                    case Side::kFront:
                        front.polygons.push_back(p);
                        break;
                    case Side::kBack:
                        back.polygons.push_back(p);
                        break;
                    case Side::kStraddle: {
                        auto [f, b] = split(plane, p);
                        front.polygons.push_back(f);
                        back.polygons.push_back(b);
                        if (double(++alive) > bound)
                            return errorStatus(
                                ErrorCode::kOutOfRange,
                                fmt::format("BSP build exceeded {} fragments for {} triangles "
                                            "(BspConfig::maxFragmentsPerTriangle = {})",
                                            alive, inTree, mConfig.maxFragmentsPerTriangle));
                        break;
                    }
                }
            }
            task.polygons = {};  // release before descending: keeps pending memory O(alive)

            BspNode node;
            node.plane = plane;
            node.parent = task.parent;
            node.firstFragment = uint32_t(tree.mFragments.size());
            node.fragmentCount = uint32_t(coplanar.size());
            for (uint32_t p : coplanar) emitFragment(&tree, p, uint32_t(nodeIndex));
            tree.mNodes.push_back(node);
            // Depth first (front side first): pending lists hold each alive polygon once.
            if (!back.polygons.empty()) stack.push_back(std::move(back));
            if (!front.polygons.empty()) stack.push_back(std::move(front));
        }

        computeSubtreeBoxes(&tree);
        BspStats& s = tree.mStats;
        s.fragments = tree.mFragments.size();
        s.nodes = tree.mNodes.size();
        s.vertexCount = tree.mVertices.size();
        s.memoryBytes = tree.mNodes.size() * sizeof(BspNode) +
                        tree.mFragments.size() * (sizeof(BspFragment) + sizeof(uint32_t)) +
                        tree.mVertices.size() * sizeof(Vec3) +
                        tree.mSubtreeBoxes.size() * sizeof(Aabb);
        std::vector<uint8_t> pieces(scene.triangleCount(), 0);
        for (const BspFragment& f : tree.mFragments)
            pieces[f.sourceTriangle] = uint8_t(std::min(2, pieces[f.sourceTriangle] + 1));
        s.splitTriangles = size_t(std::count(pieces.begin(), pieces.end(), uint8_t(2)));
        return tree;
    }

private:
    // Children are stored after their parent (depth-first build), so one pass from the last node
    // to the first finishes every subtree before its parent takes it in.
    static void computeSubtreeBoxes(BspTree* tree) {
        tree->mSubtreeBoxes.assign(tree->mNodes.size(), Aabb{});
        for (size_t i = tree->mNodes.size(); i-- > 0;) {
            const BspNode& n = tree->mNodes[i];
            Aabb& box = tree->mSubtreeBoxes[i];
            for (uint32_t f = n.firstFragment; f < n.firstFragment + n.fragmentCount; ++f)
                for (const Vec3& v : tree->fragmentVertices(f)) box.extend(v);
            if (n.parent != BspTree::kNoNode) tree->mSubtreeBoxes[size_t(n.parent)].extend(box);
        }
    }

    // Computes every triangle's plane and makes a work polygon of each non-degenerate one.
    std::vector<uint32_t> collectTriangles(const Scene& scene, size_t* degenerate) {
        size_t count = scene.triangleCount();
        mPlanes.assign(count, Vec4(0.0f));
        mPolygons.reserve(count);
        mPool.reserve(3 * count);
        std::vector<uint32_t> ids;
        ids.reserve(count);
        for (size_t m = 0; m < scene.meshes.size(); ++m) {
            const Mesh& mesh = scene.meshes[m];
            for (size_t t = 0; t < mesh.triangleCount(); ++t) {
                size_t global = scene.firstTriangle(m) + t;
                const Vec3& a = mesh.positions[mesh.indices[3 * t]];
                const Vec3& b = mesh.positions[mesh.indices[3 * t + 1]];
                const Vec3& c = mesh.positions[mesh.indices[3 * t + 2]];
                if (!trianglePlane(a, b, c, &mPlanes[global])) {
                    ++*degenerate;
                    continue;
                }
                ids.push_back(uint32_t(mPolygons.size()));
                mPolygons.push_back({uint32_t(global), uint32_t(mPool.size()), 3});
                mPool.insert(mPool.end(), {a, b, c});
            }
        }
        return ids;
    }

    Side classify(const Vec4& plane, const WorkPolygon& p) const {
        bool anyFront = false, anyBack = false;
        const Vec3* v = mPool.data() + p.firstVertex;
        for (uint32_t i = 0; i < p.vertexCount; ++i) {
            float d = planeDistance(plane, v[i]);
            anyFront |= d > mEpsilon;
            anyBack |= d < -mEpsilon;
        }
        if (anyFront && anyBack) return Side::kStraddle;
        if (anyFront) return Side::kFront;
        if (anyBack) return Side::kBack;
        return Side::kCoplanar;
    }

    // Picks the splitting polygon of a node: among up to candidatePlanes polygons drawn at
    // random (all of them when the node holds that few), the one whose plane scores lowest
    // (splitWeight * splits + |front - back|) over up to scoreSample polygons of the node. The
    // bounded sample keeps a node's choice O(candidates * sample) however large the node; a
    // random rather than first-N draw avoids the meshes' spatial order biasing the choice.
    uint32_t chooseSplitter(const std::vector<uint32_t>& polygons) {
        size_t n = polygons.size();
        size_t candidates = std::min(n, size_t(mConfig.candidatePlanes));
        size_t samples = std::min(n, size_t(mConfig.scoreSample));
        auto draw = [&](size_t i, size_t want) {
            return want == n ? polygons[i] : polygons[nextRandom(&mRandom) % n];
        };
        mSample.resize(samples);
        for (size_t i = 0; i < samples; ++i) mSample[i] = draw(i, samples);
        uint32_t best = polygons[0];
        float bestScore = std::numeric_limits<float>::infinity();
        for (size_t c = 0; c < candidates; ++c) {
            uint32_t candidate = draw(c, candidates);
            const Vec4& plane = mPlanes[mPolygons[candidate].source];
            int splits = 0, fronts = 0, backs = 0;
            for (uint32_t q : mSample) {
                switch (classify(plane, mPolygons[q])) {
                    case Side::kCoplanar:
                        break;
                    case Side::kFront:
                        ++fronts;
                        break;
                    case Side::kBack:
                        ++backs;
                        break;
                    case Side::kStraddle:
                        ++splits;
                        break;
                }
            }
            float score = mConfig.splitWeight * float(splits) + float(std::abs(fronts - backs));
            if (score < bestScore) {
                bestScore = score;
                best = candidate;
            }
        }
        return best;
    }

    // Cuts a straddling convex polygon into its front and back pieces (Sutherland-Hodgman
    // against one plane); vertices within epsilon of the plane go to both. Returns their ids.
    std::pair<uint32_t, uint32_t> split(const Vec4& plane, uint32_t id) {
        WorkPolygon p = mPolygons[id];  // copy: the pushes below may move mPolygons
        mFrontVerts.clear();
        mBackVerts.clear();
        for (uint32_t i = 0; i < p.vertexCount; ++i) {
            Vec3 a = mPool[p.firstVertex + i];
            Vec3 b = mPool[p.firstVertex + (i + 1) % p.vertexCount];
            float da = planeDistance(plane, a);
            float db = planeDistance(plane, b);
            if (da > mEpsilon) {
                mFrontVerts.push_back(a);
            } else if (da < -mEpsilon) {
                mBackVerts.push_back(a);
            } else {
                mFrontVerts.push_back(a);
                mBackVerts.push_back(a);
            }
            if ((da > mEpsilon && db < -mEpsilon) || (da < -mEpsilon && db > mEpsilon)) {
                // Interpolate from the front end so both neighbours of a shared edge get the
                // same point.
                Vec3 from = da > 0.0f ? a : b, to = da > 0.0f ? b : a;
                float dFrom = da > 0.0f ? da : db, dTo = da > 0.0f ? db : da;
                Vec3 cut = from + (to - from) * (dFrom / (dFrom - dTo));
                mFrontVerts.push_back(cut);
                mBackVerts.push_back(cut);
            }
        }
        auto add = [&](const std::vector<Vec3>& verts) {
            uint32_t newId = uint32_t(mPolygons.size());
            mPolygons.push_back({p.source, uint32_t(mPool.size()), uint32_t(verts.size())});
            mPool.insert(mPool.end(), verts.begin(), verts.end());
            return newId;
        };
        uint32_t f = add(mFrontVerts);
        return {f, add(mBackVerts)};
    }

    void emitFragment(BspTree* tree, uint32_t id, uint32_t node) {
        const WorkPolygon& p = mPolygons[id];
        tree->mFragments.push_back({p.source, uint32_t(tree->mVertices.size()), p.vertexCount});
        tree->mFragmentNode.push_back(node);
        tree->mVertices.insert(tree->mVertices.end(), mPool.begin() + p.firstVertex,
                               mPool.begin() + p.firstVertex + p.vertexCount);
    }

    const BspConfig& mConfig;
    float mEpsilon;
    uint64_t mRandom;
    std::vector<Vec4> mPlanes;  // per scene-global triangle
    std::vector<WorkPolygon> mPolygons;
    std::vector<Vec3> mPool;  // work polygons' vertices; pieces of split polygons stay as garbage
    std::vector<uint32_t> mSample;
    std::vector<Vec3> mFrontVerts, mBackVerts;
};

Result<BspTree> BspTree::build(const Scene& scene, const BspConfig& config) {
    if (config.candidatePlanes < 1 || config.scoreSample < 1 || !(config.splitWeight >= 0.0f) ||
        !(config.coplanarEpsilon >= 0.0f) || !(config.maxFragmentsPerTriangle >= 1.0f))
        return errorStatus(
            ErrorCode::kInvalidArgument,
            fmt::format("BSP config out of range: candidatePlanes {} and "
                        "scoreSample {} must be >= 1, splitWeight {} and "
                        "coplanarEpsilon {} >= 0, maxFragmentsPerTriangle {} >= 1",
                        config.candidatePlanes, config.scoreSample, config.splitWeight,
                        config.coplanarEpsilon, config.maxFragmentsPerTriangle));
    if (scene.triangleCount() == 0) return BspTree();
    if (scene.triangleCount() > size_t(std::numeric_limits<int32_t>::max()))
        return errorStatus(
            ErrorCode::kOutOfRange,
            fmt::format("BSP of {} triangles: at most 2^31 - 1 supported", scene.triangleCount()));
    // Scale of the coordinates: plane distances carry rounding proportional to it.
    const Aabb& bounds = scene.bounds();
    Vec3 far = glm::max(glm::abs(bounds.lo), glm::abs(bounds.hi));
    float scale = std::max({far.x, far.y, far.z}) + bounds.diagonal();
    return BspBuilder(config, config.coplanarEpsilon * scale).run(scene);
}

}  // namespace plx::scene
