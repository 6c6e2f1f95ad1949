// BSP tree (Fuchs, Kedem, Naylor): fragments cover their triangles, lie on their side of every
// ancestor plane, and the front-to-back walk never puts a polygon after one it hides.

#include <algorithm>
#include <random>

#include <gtest/gtest.h>

#include <plx/scene/bsp.h>
#include <plx/scene/generators.h>
#include <plx/scene/primitives.h>

namespace plx::scene {
namespace {

Scene sceneOf(const std::vector<Vec3>& corners) {
    Scene scene;
    Mesh mesh;
    mesh.positions = corners;
    for (uint32_t i = 0; i < corners.size(); ++i) mesh.indices.push_back(i);
    scene.meshes.push_back(std::move(mesh));
    Status status = scene.finalize();
    EXPECT_TRUE(status.isOk()) << status.toString();
    return scene;
}

// Random small triangles, one in each occupied cell of a grid of unit cells (kept 0.1 inside
// the cell's walls), so no two triangles touch or interpenetrate.
Scene randomCellTriangles(std::mt19937* rng, int cellsPerAxis, float occupancy) {
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    std::vector<Vec3> corners;
    for (int x = 0; x < cellsPerAxis; ++x)
        for (int y = 0; y < cellsPerAxis; ++y)
            for (int z = 0; z < cellsPerAxis; ++z) {
                if (unit(*rng) > occupancy) continue;
                Vec3 cell{float(x), float(y), float(z)};
                for (int k = 0; k < 3; ++k)
                    corners.push_back(cell + Vec3(0.1f) +
                                      0.8f * Vec3(unit(*rng), unit(*rng), unit(*rng)));
            }
    return sceneOf(corners);
}

// Random triangles about 3 units across in a 10-unit cube: many cross each other's planes.
Scene randomCrossingTriangles(std::mt19937* rng, int count) {
    std::uniform_real_distribution<float> centre(-5.0f, 5.0f), offset(-1.5f, 1.5f);
    std::vector<Vec3> corners;
    for (int i = 0; i < count; ++i) {
        Vec3 c{centre(*rng), centre(*rng), centre(*rng)};
        for (int k = 0; k < 3; ++k)
            corners.push_back(c + Vec3{offset(*rng), offset(*rng), offset(*rng)});
    }
    return sceneOf(corners);
}

Vec3 triangleCorner(const Scene& scene, size_t global, int k) {
    size_t m = scene.meshOfTriangle(uint32_t(global));
    const Mesh& mesh = scene.meshes[m];
    size_t t = global - scene.firstTriangle(m);
    return mesh.positions[mesh.indices[3 * t + size_t(k)]];
}

double polygonArea(std::span<const Vec3> v) {
    glm::dvec3 sum(0.0);
    for (size_t i = 1; i + 1 < v.size(); ++i)
        sum += glm::cross(glm::dvec3(v[i] - v[0]), glm::dvec3(v[i + 1] - v[0]));
    return 0.5 * glm::length(sum);
}

// Ray parameter t where eye + t * (target - eye) crosses the convex polygon, or -1.
float rayHit(const Vec3& eye, const Vec3& target, std::span<const Vec3> poly) {
    Vec3 dir = target - eye;
    for (size_t i = 1; i + 1 < poly.size(); ++i) {
        // Moller-Trumbore on the fan triangle (0, i, i + 1).
        Vec3 e1 = poly[i] - poly[0], e2 = poly[i + 1] - poly[0];
        Vec3 p = glm::cross(dir, e2);
        float det = glm::dot(e1, p);
        if (std::abs(det) < 1e-12f) continue;
        Vec3 s = eye - poly[0];
        float u = glm::dot(s, p) / det;
        Vec3 q = glm::cross(s, e1);
        float v = glm::dot(dir, q) / det;
        if (u < 0.0f || v < 0.0f || u + v > 1.0f) continue;
        return glm::dot(e2, q) / det;
    }
    return -1.0f;
}

// A point strictly inside a convex polygon: a random convex combination of its corners.
Vec3 pointIn(std::span<const Vec3> poly, std::mt19937* rng) {
    std::uniform_real_distribution<float> unit(0.05f, 1.0f);
    Vec3 sum(0.0f);
    float weight = 0.0f;
    for (const Vec3& v : poly) {
        float w = unit(*rng);
        sum += w * v;
        weight += w;
    }
    return sum / weight;
}

// Checks that no fragment hides (part of) a fragment that comes before it in `order`: for
// sampled points on each fragment, the ray from the eye must not cross a later fragment first.
// Returns the number of violations.
size_t orderViolations(const BspTree& tree, const Vec3& eye, const std::vector<uint32_t>& order,
                       std::mt19937* rng, int samplesPerFragment) {
    size_t violations = 0;
    for (size_t i = 0; i < order.size(); ++i) {
        auto earlier = tree.fragmentVertices(order[i]);
        for (int s = 0; s < samplesPerFragment; ++s) {
            Vec3 target = pointIn(earlier, rng);
            for (size_t j = i + 1; j < order.size(); ++j) {
                if (tree.fragment(order[j]).sourceTriangle ==
                    tree.fragment(order[i]).sourceTriangle)
                    continue;
                float t = rayHit(eye, target, tree.fragmentVertices(order[j]));
                if (t > 0.0f && t < 1.0f - 1e-4f) ++violations;
            }
        }
    }
    return violations;
}

// The tree of random cell triangles (randomCellTriangles); the build must succeed.
BspTree cellTree(uint32_t seed, int cellsPerAxis, float occupancy, std::mt19937* rng) {
    rng->seed(seed);
    Scene scene = randomCellTriangles(rng, cellsPerAxis, occupancy);
    auto tree = BspTree::build(scene);
    EXPECT_TRUE(tree.isOk()) << tree.status().toString();
    return tree.isOk() ? std::move(*tree) : BspTree();
}

Vec3 randomEye(std::mt19937* rng, float lo, float hi) {
    std::uniform_real_distribution<float> d(lo, hi);
    return {d(*rng), d(*rng), d(*rng)};
}

TEST(Bsp, EmptySceneGivesAnEmptyTree) {
    Scene scene;
    auto tree = BspTree::build(scene);
    ASSERT_TRUE(tree.isOk()) << tree.status().toString();
    EXPECT_TRUE(tree->empty());
    EXPECT_EQ(tree->root(), BspTree::kNoNode);
    EXPECT_EQ(tree->stats().fragmentsPerTriangle(), 0.0);
    size_t visited = 0;
    tree->forEachFrontToBack(Vec3(0.0f), [&](uint32_t) { ++visited; });
    EXPECT_EQ(visited, 0u);
}

TEST(Bsp, DegenerateTrianglesAreSkipped) {
    Scene scene = sceneOf({{0, 0, 0},
                           {1, 0, 0},
                           {0, 1, 0},  // good, global 0
                           {0, 0, 1},
                           {1, 0, 1},
                           {2, 0, 1},  // collinear
                           {5, 5, 5},
                           {5, 5, 5},
                           {6, 5, 5},  // repeated corner
                           {0, 0, 2},
                           {1, 0, 2},
                           {0, 1, 2}});  // good, global 3
    auto tree = BspTree::build(scene);
    ASSERT_TRUE(tree.isOk()) << tree.status().toString();
    EXPECT_EQ(tree->stats().sourceTriangles, 4u);
    EXPECT_EQ(tree->stats().degenerateSkipped, 2u);
    ASSERT_EQ(tree->fragmentCount(), 2u);
    std::vector<uint32_t> order;
    tree->frontToBack(Vec3(0.2f, 0.2f, 10.0f), &order);
    ASSERT_EQ(order.size(), 2u);
    EXPECT_EQ(tree->fragment(order[0]).sourceTriangle, 3u);  // z = 2 is nearer the eye at z = 10
    EXPECT_EQ(tree->fragment(order[1]).sourceTriangle, 0u);
    tree->frontToBack(Vec3(0.2f, 0.2f, -10.0f), &order);
    EXPECT_EQ(tree->fragment(order[0]).sourceTriangle, 0u);
}

TEST(Bsp, RejectsConfigsOutOfRange) {
    Scene scene = sceneOf({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
    BspConfig config;
    config.candidatePlanes = 0;
    EXPECT_EQ(BspTree::build(scene, config).status().code(), ErrorCode::kInvalidArgument);
    config = {};
    config.coplanarEpsilon = -1.0f;
    EXPECT_EQ(BspTree::build(scene, config).status().code(), ErrorCode::kInvalidArgument);
}

TEST(Bsp, FragmentBoundIsEnforced) {
    // Two triangles crossing each other's planes: whichever is chosen first splits the other.
    Scene scene = sceneOf(
        {{-1, 0, -1}, {1, 0, -1}, {0, 0, 1}, {0, -1, -0.5f}, {0, 1, -0.5f}, {0.01f, 0, 0.5f}});
    BspConfig config;
    config.maxFragmentsPerTriangle = 1.0f;
    auto tree = BspTree::build(scene, config);
    EXPECT_EQ(tree.status().code(), ErrorCode::kOutOfRange) << tree.status().toString();
    config.maxFragmentsPerTriangle = 1.5f;
    auto ok = BspTree::build(scene, config);
    ASSERT_TRUE(ok.isOk()) << ok.status().toString();
    EXPECT_EQ(ok->fragmentCount(), 3u);
    EXPECT_EQ(ok->stats().splitTriangles, 1u);
}

// Every tree triangle is covered exactly by its fragments: areas add up, and every fragment
// lies in its source triangle's plane. Large random triangles cut each other many times.
TEST(Bsp, FragmentsCoverTheirTriangles) {
    std::mt19937 rng(7);
    Scene scene = randomCrossingTriangles(&rng, 150);
    auto tree = BspTree::build(scene);
    ASSERT_TRUE(tree.isOk()) << tree.status().toString();
    EXPECT_GT(tree->stats().splitTriangles, 10u);
    EXPECT_EQ(tree->stats().fragments, tree->fragmentCount());

    std::vector<double> area(scene.triangleCount(), 0.0);
    for (size_t f = 0; f < tree->fragmentCount(); ++f) {
        auto v = tree->fragmentVertices(f);
        ASSERT_GE(v.size(), 3u);
        uint32_t source = tree->fragment(f).sourceTriangle;
        area[source] += polygonArea(v);
        Vec3 a = triangleCorner(scene, source, 0);
        Vec3 n = glm::normalize(
            glm::cross(triangleCorner(scene, source, 1) - a, triangleCorner(scene, source, 2) - a));
        for (const Vec3& p : v) EXPECT_NEAR(glm::dot(n, p - a), 0.0f, 1e-4f);
    }
    for (size_t t = 0; t < scene.triangleCount(); ++t) {
        Vec3 a = triangleCorner(scene, t, 0);
        double expected = polygonArea(
            std::vector<Vec3>{a, triangleCorner(scene, t, 1), triangleCorner(scene, t, 2)});
        EXPECT_NEAR(area[t], expected, 1e-4 * expected + 1e-6) << "triangle " << t;
    }
}

// A fragment in a node's front subtree lies in front of (or within epsilon of) that node's
// plane, and one in its back subtree behind it.
TEST(Bsp, FragmentsLieOnTheirSideOfEveryAncestorPlane) {
    std::mt19937 rng(11);
    Scene scene = randomCrossingTriangles(&rng, 150);
    auto tree = BspTree::build(scene);
    ASSERT_TRUE(tree.isOk());
    // Fragment -> node: each node's fragments are a contiguous range.
    std::vector<int32_t> nodeOf(tree->fragmentCount(), BspTree::kNoNode);
    for (size_t n = 0; n < tree->nodeCount(); ++n) {
        const BspNode& node = tree->node(n);
        for (uint32_t f = node.firstFragment; f < node.firstFragment + node.fragmentCount; ++f)
            nodeOf[f] = int32_t(n);
    }
    float tolerance = 2.0f * tree->epsilon();
    size_t checked = 0;
    for (size_t f = 0; f < tree->fragmentCount(); ++f) {
        ASSERT_NE(nodeOf[f], BspTree::kNoNode);
        int32_t child = nodeOf[f];
        for (int32_t parent = tree->node(size_t(child)).parent; parent != BspTree::kNoNode;
             child = parent, parent = tree->node(size_t(parent)).parent) {
            const BspNode& p = tree->node(size_t(parent));
            bool inFront = p.front == child;
            EXPECT_TRUE(inFront || p.back == child);
            for (const Vec3& v : tree->fragmentVertices(f)) {
                float d = planeDistance(p.plane, v);
                if (inFront)
                    EXPECT_GE(d, -tolerance);
                else
                    EXPECT_LE(d, tolerance);
                ++checked;
            }
        }
    }
    EXPECT_GT(checked, tree->fragmentCount());
}

// Fu, Bao, Peng use the walk as a visibility priority: nothing later may hide anything earlier.
// Random non-intersecting triangles, one tree, many eyes inside and outside the cloud.
TEST(Bsp, FrontToBackOrderAgreesWithDepthFromManyEyes) {
    std::mt19937 rng;
    BspTree tree = cellTree(3, 5, 0.6f, &rng);
    ASSERT_GT(tree.fragmentCount(), 40u);
    std::vector<uint32_t> order, backOrder;
    for (int e = 0; e < 12; ++e) {
        Vec3 eye = randomEye(&rng, e < 6 ? 0.0f : -8.0f, e < 6 ? 5.0f : 13.0f);
        tree.frontToBack(eye, &order);
        // A permutation of all fragments.
        std::vector<uint32_t> sorted = order;
        std::sort(sorted.begin(), sorted.end());
        ASSERT_EQ(sorted.size(), tree.fragmentCount());
        for (size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], i);
        EXPECT_EQ(orderViolations(tree, eye, order, &rng, 4), 0u) << "eye " << e;

        backOrder.clear();
        tree.forEachBackToFront(eye, [&](uint32_t f) { backOrder.push_back(f); });
        std::reverse(backOrder.begin(), backOrder.end());
        EXPECT_EQ(orderViolations(tree, eye, backOrder, &rng, 2), 0u) << "eye " << e;
    }
}

// The checker itself finds a wrong order: reversing a front-to-back order of a scene where
// some fragment hides another must give violations (keeps the property test from passing
// vacuously).
TEST(Bsp, OrderCheckerDetectsAReversedOrder) {
    std::mt19937 rng;
    BspTree tree = cellTree(5, 4, 0.9f, &rng);
    std::vector<uint32_t> order;
    Vec3 eye(1.5f, 1.5f, 12.0f);
    tree.frontToBack(eye, &order);
    std::reverse(order.begin(), order.end());
    EXPECT_GT(orderViolations(tree, eye, order, &rng, 4), 0u);
}

TEST(Bsp, WalkStopsWhenTheCallbackSaysSo) {
    std::mt19937 rng;
    BspTree tree = cellTree(9, 4, 0.8f, &rng);
    ASSERT_GT(tree.fragmentCount(), 10u);
    std::vector<uint32_t> full, partial;
    Vec3 eye(-3.0f, 2.0f, 9.0f);
    tree.frontToBack(eye, &full);
    tree.forEachFrontToBack(eye, [&](uint32_t f) {
        partial.push_back(f);
        return partial.size() < 7;
    });
    ASSERT_EQ(partial.size(), 7u);
    EXPECT_TRUE(std::equal(partial.begin(), partial.end(), full.begin()));
}

// Subtree boxes enclose their fragments and their children's boxes; the pruned walk accepting
// everything is the plain walk, and with a box predicate it emits exactly the plain walk's
// fragments whose node and ancestors pass, in the same order.
TEST(Bsp, PrunedWalkKeepsThePlainOrderOfTheAcceptedSubtrees) {
    std::mt19937 rng;
    BspTree tree = cellTree(9, 4, 0.8f, &rng);
    ASSERT_GT(tree.nodeCount(), 10u);
    std::vector<int32_t> fragmentNode(tree.fragmentCount());
    for (size_t i = 0; i < tree.nodeCount(); ++i) {
        const BspNode& n = tree.node(i);
        const Aabb& box = tree.subtreeBox(i);
        for (uint32_t f = n.firstFragment; f < n.firstFragment + n.fragmentCount; ++f) {
            fragmentNode[f] = int32_t(i);
            for (const Vec3& v : tree.fragmentVertices(f))
                EXPECT_TRUE(glm::all(glm::lessThanEqual(box.lo, v)) &&
                            glm::all(glm::lessThanEqual(v, box.hi)));
        }
        for (int32_t c : {n.front, n.back}) {
            if (c == BspTree::kNoNode) continue;
            EXPECT_TRUE(glm::all(glm::lessThanEqual(box.lo, tree.subtreeBox(size_t(c)).lo)) &&
                        glm::all(glm::lessThanEqual(tree.subtreeBox(size_t(c)).hi, box.hi)));
        }
    }
    for (Vec3 eye : {Vec3(-3.0f, 2.0f, 9.0f), Vec3(1.5f, 1.5f, 1.5f)}) {
        std::vector<uint32_t> plain, all, pruned, expected;
        tree.frontToBack(eye, &plain);
        size_t reached = tree.forEachFrontToBackPruned(
            eye, [](int32_t, const Aabb&) { return true; },
            [&](uint32_t f) { all.push_back(f); });
        EXPECT_EQ(all, plain);
        EXPECT_EQ(reached, tree.nodeCount());
        Aabb region{Vec3(0.0f, 0.0f, 0.0f), Vec3(2.0f, 4.0f, 2.5f)};
        auto passes = [&](const Aabb& b) {
            return glm::all(glm::lessThanEqual(b.lo, region.hi)) &&
                   glm::all(glm::lessThanEqual(region.lo, b.hi));
        };
        size_t tested = tree.forEachFrontToBackPruned(
            eye, [&](int32_t, const Aabb& b) { return passes(b); },
            [&](uint32_t f) { pruned.push_back(f); });
        for (uint32_t f : plain) {
            bool keep = true;
            for (int32_t n = fragmentNode[f]; n != BspTree::kNoNode; n = tree.node(size_t(n)).parent)
                keep = keep && passes(tree.subtreeBox(size_t(n)));
            if (keep) expected.push_back(f);
        }
        EXPECT_EQ(pruned, expected);
        EXPECT_LT(pruned.size(), plain.size());
        EXPECT_GT(pruned.size(), 0u);
        EXPECT_LT(tested, tree.nodeCount());
    }
}

// A convex solid makes every face plane leave all other faces on one side: the tree degenerates
// into a chain as deep as the solid has face planes. Built and walked without recursion.
TEST(Bsp, ConvexSolidBuildsAChainAndWalksIt) {
    Scene scene;
    Mesh mesh;
    appendCylinder(&mesh, Vec3(0.0f), 1.0f, 2.0f, 1000);
    scene.meshes.push_back(std::move(mesh));
    ASSERT_TRUE(scene.finalize().isOk());
    auto tree = BspTree::build(scene);
    ASSERT_TRUE(tree.isOk()) << tree.status().toString();
    EXPECT_EQ(tree->stats().splitTriangles, 0u);
    EXPECT_EQ(tree->fragmentCount(), scene.triangleCount());
    EXPECT_GT(tree->stats().maxDepth, 500u);
    // Seen from outside, every face turned towards the eye comes before every face turned away.
    Vec3 eye(4.0f, 1.0f, 3.0f);
    std::vector<uint32_t> order;
    tree->frontToBack(eye, &order);
    ASSERT_EQ(order.size(), tree->fragmentCount());
    bool seenAway = false;
    size_t facingAfterAway = 0;
    for (uint32_t f : order) {
        bool facing = planeDistance(tree->fragmentPlane(f), eye) > 0.0f;
        if (!facing)
            seenAway = true;
        else if (seenAway)
            ++facingAfterAway;
    }
    EXPECT_EQ(facingAfterAway, 0u);
}

// Real geometry (boxes resting on the floor, touching partitions): for rays from the eye to
// random points on random fragments, every fragment the ray crosses first comes earlier in the
// walk. Interpenetrating solids would be cut by the tree, so this holds for any scene.
TEST(Bsp, FrontToBackOrderAgreesWithDepthInTheOffice) {
    auto scene = generateOffice(1);
    ASSERT_TRUE(scene.isOk());
    auto tree = BspTree::build(*scene);
    ASSERT_TRUE(tree.isOk());
    std::mt19937 rng(12);
    std::uniform_int_distribution<size_t> anyFragment(0, tree->fragmentCount() - 1);
    std::uniform_real_distribution<float> floorPos(0.2f, 7.8f), height(0.3f, 2.5f);
    std::vector<uint32_t> order, position(tree->fragmentCount());
    size_t hits = 0, violations = 0;
    for (int e = 0; e < 4; ++e) {
        Vec3 eye = e == 0 ? defaultViewpoint(*scene).eyePos
                          : Vec3{floorPos(rng), height(rng), floorPos(rng)};
        tree->frontToBack(eye, &order);
        for (size_t i = 0; i < order.size(); ++i) position[order[i]] = uint32_t(i);
        for (int r = 0; r < 150; ++r) {
            size_t target = anyFragment(rng);
            Vec3 point = pointIn(tree->fragmentVertices(target), &rng);
            for (size_t f = 0; f < tree->fragmentCount(); ++f) {
                if (tree->fragment(f).sourceTriangle == tree->fragment(target).sourceTriangle)
                    continue;
                float t = rayHit(eye, point, tree->fragmentVertices(f));
                if (!(t > 0.0f && t < 1.0f - 1e-4f)) continue;
                ++hits;
                violations += position[f] > position[target];
            }
        }
    }
    EXPECT_GT(hits, 100u);
    EXPECT_EQ(violations, 0u);
}

// The office's triangles are all in the tree, their fragments cover them, and the tree stays
// within a small multiple of the triangle count.
TEST(Bsp, OfficeBuildsWithFewSplits) {
    auto scene = generateOffice(2);
    ASSERT_TRUE(scene.isOk());
    auto tree = BspTree::build(*scene);
    ASSERT_TRUE(tree.isOk()) << tree.status().toString();
    const BspStats& s = tree->stats();
    EXPECT_EQ(s.sourceTriangles, scene->triangleCount());
    EXPECT_LT(s.fragmentsPerTriangle(), 3.0);
    std::vector<double> area(scene->triangleCount(), 0.0);
    for (size_t f = 0; f < tree->fragmentCount(); ++f)
        area[tree->fragment(f).sourceTriangle] += polygonArea(tree->fragmentVertices(f));
    size_t uncovered = 0;
    for (size_t t = 0; t < scene->triangleCount(); ++t) {
        Vec3 a = triangleCorner(*scene, t, 0);
        double expected = polygonArea(
            std::vector<Vec3>{a, triangleCorner(*scene, t, 1), triangleCorner(*scene, t, 2)});
        if (std::abs(area[t] - expected) > 1e-3 * expected + 1e-7) ++uncovered;
    }
    EXPECT_EQ(uncovered, 0u);
}

TEST(Bsp, SameSeedBuildsTheSameTree) {
    auto scene = generateOffice(1);
    ASSERT_TRUE(scene.isOk());
    auto a = BspTree::build(*scene);
    auto b = BspTree::build(*scene);
    ASSERT_TRUE(a.isOk() && b.isOk());
    EXPECT_EQ(a->fragmentCount(), b->fragmentCount());
    EXPECT_EQ(a->nodeCount(), b->nodeCount());
    std::vector<uint32_t> oa, ob;
    a->frontToBack(Vec3(1.0f, 1.7f, 1.0f), &oa);
    b->frontToBack(Vec3(1.0f, 1.7f, 1.0f), &ob);
    EXPECT_EQ(oa, ob);
}

}  // namespace
}  // namespace plx::scene
