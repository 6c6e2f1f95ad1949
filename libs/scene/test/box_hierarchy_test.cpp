// Box hierarchy and per-hole flags (Fu, Bao, Peng section 3): the flags never reject a triangle
// whose projection reaches the hole's rectangle, they follow the paper's node rule exactly, they
// reject most of the office for a small hole, and a reused flag set equals a fresh one.

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>
#include <random>

#include <gtest/gtest.h>

#include <plx/scene/box_hierarchy.h>
#include <plx/scene/generators.h>

namespace plx::scene {
namespace {

Scene randomTriangles(std::mt19937* rng, int count) {
    std::uniform_real_distribution<float> centre(-5.0f, 5.0f), size(0.02f, 2.0f), unit(-1.0f, 1.0f);
    Scene scene;
    Mesh mesh;
    for (int i = 0; i < count; ++i) {
        Vec3 c{centre(*rng), centre(*rng), centre(*rng)};
        float s = size(*rng);
        for (int k = 0; k < 3; ++k) {
            mesh.indices.push_back(uint32_t(mesh.positions.size()));
            mesh.positions.push_back(c + s * Vec3{unit(*rng), unit(*rng), unit(*rng)});
        }
    }
    scene.meshes.push_back(std::move(mesh));
    EXPECT_TRUE(scene.finalize().isOk());
    return scene;
}

std::array<Vec3, 3> corners(const Scene& scene, size_t global) {
    size_t m = scene.meshOfTriangle(uint32_t(global));
    const Mesh& mesh = scene.meshes[m];
    size_t t = global - scene.firstTriangle(m);
    return {mesh.positions[mesh.indices[3 * t]], mesh.positions[mesh.indices[3 * t + 1]],
            mesh.positions[mesh.indices[3 * t + 2]]};
}

Camera randomCamera(std::mt19937* rng) {
    std::uniform_real_distribution<float> eye(-9.0f, 9.0f), target(-3.0f, 3.0f),
        nearPlane(0.05f, 1.0f), fov(30.0f, 100.0f);
    for (;;) {
        CameraDesc desc;
        desc.eyePos = {eye(*rng), eye(*rng), eye(*rng)};
        desc.targetPos = {target(*rng), target(*rng), target(*rng)};
        desc.nearPlane = nearPlane(*rng);
        desc.farPlane = 100.0f;
        desc.fovYDegrees = fov(*rng);
        desc.width = 320;
        desc.height = 240;
        auto camera = Camera::create(desc);
        if (camera) return *camera;
    }
}

PixelRect randomRect(std::mt19937* rng) {
    std::uniform_int_distribution<int> x(-40, 340), y(-40, 260), side(1, 120);
    PixelRect r;
    r.x0 = x(*rng);
    r.y0 = y(*rng);
    r.x1 = r.x0 + side(*rng);
    r.y1 = r.y0 + side(*rng);
    return r;
}

// Brute force: does some sampled point of the triangle, not clipped by the near plane, project
// into the rectangle's area? Points on a 16-step barycentric grid (corners and edges included).
bool sampledOverlap(const Camera& camera, const std::array<Vec3, 3>& tri, const PixelRect& r) {
    constexpr int kSteps = 16;
    for (int i = 0; i <= kSteps; ++i)
        for (int j = 0; i + j <= kSteps; ++j) {
            float u = float(i) / kSteps, v = float(j) / kSteps;
            Vec3 p = tri[0] + u * (tri[1] - tri[0]) + v * (tri[2] - tri[0]);
            Vec4 clip = camera.clipFromWorld() * Vec4(p, 1.0f);
            if (clip.w < camera.desc().nearPlane) continue;
            Vec2 px = camera.pixelFromClip(clip);
            if (px.x >= float(r.x0) && px.x <= float(r.x1) && px.y >= float(r.y0) &&
                px.y <= float(r.y1))
                return true;
        }
    return false;
}

// Fu, Bao, Peng's rule written directly: a triangle is positive iff every node on its path
// from the root, its leaf included, passes the projected-box test.
std::vector<bool> referenceFlags(const BoxHierarchy& h, const Camera& camera, const PixelRect& r,
                                 size_t triangleCount) {
    std::vector<bool> positive(triangleCount, false);
    std::function<void(size_t, bool)> mark = [&](size_t index, bool ancestorsPass) {
        const BoxNode& node = h.node(index);
        bool pass = ancestorsPass && boxMayCoverRect(camera, node.box, r);
        if (node.isLeaf()) {
            for (uint32_t i = node.first; i < node.first + node.count; ++i)
                positive[h.triangles()[i]] = pass;
            return;
        }
        mark(index + 1, pass);
        mark(node.first, pass);
    };
    if (h.nodeCount() > 0) mark(0, true);
    return positive;
}

// Every triangle in exactly one leaf of at most leafSize, every node's box around its children's
// boxes and its leaves' corners, the depth within the bound of every scene.
void expectWellFormed(const Scene& scene, const BoxHierarchy& h, uint32_t leafSize) {
    std::vector<uint32_t> sorted = h.triangles();
    std::sort(sorted.begin(), sorted.end());
    ASSERT_EQ(sorted.size(), scene.triangleCount());
    for (size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], i);
    EXPECT_LE(h.maxDepth(), BoxHierarchy::kMaxDepth);
    size_t leafTriangles = 0;
    for (size_t n = 0; n < h.nodeCount(); ++n) {
        const BoxNode& node = h.node(n);
        auto inside = [&](const Aabb& b) {
            return glm::all(glm::greaterThanEqual(b.lo, node.box.lo)) &&
                   glm::all(glm::lessThanEqual(b.hi, node.box.hi));
        };
        if (node.isLeaf()) {
            EXPECT_LE(node.count, leafSize);
            leafTriangles += node.count;
            for (uint32_t i = node.first; i < node.first + node.count; ++i)
                for (const Vec3& p : corners(scene, h.triangles()[i]))
                    EXPECT_TRUE(inside(Aabb{p, p}));
        } else {
            EXPECT_TRUE(inside(h.node(n + 1).box));
            EXPECT_TRUE(inside(h.node(node.first).box));
        }
    }
    EXPECT_EQ(leafTriangles, scene.triangleCount());
}

BoxHierarchy buildWith(const Scene& scene, BoxSplit split, ThreadPool* pool = nullptr) {
    BoxHierarchyConfig config;
    config.split = split;
    auto h = BoxHierarchy::build(scene, config, pool);
    EXPECT_TRUE(h.isOk()) << h.status().toString();
    return h ? std::move(*h) : BoxHierarchy{};
}

TEST(BoxHierarchy, EveryTriangleOnceAndBoxesEnclose) {
    std::mt19937 rng(1);
    Scene scene = randomTriangles(&rng, 777);
    BoxHierarchy median = buildWith(scene, BoxSplit::kMedian);
    expectWellFormed(scene, median, 4);
    EXPECT_LE(median.maxDepth(), 10u);  // ceil(log2(777 / 4)) + 1 = 9
    expectWellFormed(scene, buildWith(scene, BoxSplit::kSurfaceArea), 4);
}

// Surface-area splits on geometry that defeats them: triangles growing 8-fold one after the
// other along x (each split cuts off only the largest, a chain as long as the scene; areas stay
// within float range, coordinates within kMaxCameraCoordinate) and many triangles with one
// centre (no bin boundary separates them: median splits). The chain's depth is cut at the
// surface-area depth limit, so the whole stays within kMaxDepth.
TEST(BoxHierarchy, SurfaceAreaSplitsStayWellFormedOnDegenerateScenes) {
    Scene scene;
    Mesh mesh;
    auto add = [&mesh](Vec3 corner, float size) {
        for (Vec3 d : {Vec3(0, 0, 0), Vec3(size, 0, 0), Vec3(0, size, 0)}) {
            mesh.indices.push_back(uint32_t(mesh.positions.size()));
            mesh.positions.push_back(corner + d);
        }
    };
    for (int i = -21; i <= 16; ++i) {
        const float size = std::ldexp(1.0f, 3 * i);
        add({size, 0, 0}, size);
    }
    for (int i = 0; i < 20; ++i) add({-1, -1, -1}, 1.0f);
    scene.meshes.push_back(std::move(mesh));
    ASSERT_TRUE(scene.finalize().isOk());
    BoxHierarchy h = buildWith(scene, BoxSplit::kSurfaceArea);
    expectWellFormed(scene, h, 4);
    // The chain alone (38 triangles, a level each) would run past depth 32; cut there, its last
    // triangles take at most three median levels.
    EXPECT_GT(h.maxDepth(), 32u) << "the chain stops short of the surface-area depth limit";
    EXPECT_LE(h.maxDepth(), 35u) << "the chain ran past the surface-area depth limit";
}

// Built with a pool, the subtrees below the top levels run in parallel: the same hierarchy, node
// for node, on the office (surface-area splits) and on random triangles (both splits).
TEST(BoxHierarchy, ParallelBuildEqualsSerial) {
    auto office = generateOffice(12);  // 43,584 triangles: above the parallel threshold
    ASSERT_TRUE(office.isOk());
    std::mt19937 rng(3);
    const Scene random = randomTriangles(&rng, 50000);
    ThreadPool pool(4);
    auto expectSame = [](const BoxHierarchy& serial, const BoxHierarchy& parallel) {
        ASSERT_EQ(serial.nodeCount(), parallel.nodeCount());
        EXPECT_EQ(serial.maxDepth(), parallel.maxDepth());
        EXPECT_EQ(serial.triangles(), parallel.triangles());
        for (size_t n = 0; n < serial.nodeCount(); ++n) {
            const BoxNode &a = serial.node(n), &b = parallel.node(n);
            ASSERT_TRUE(a.first == b.first && a.count == b.count && a.box.lo == b.box.lo &&
                        a.box.hi == b.box.hi)
                << "node " << n;
        }
    };
    expectSame(buildWith(*office, BoxSplit::kSurfaceArea),
               buildWith(*office, BoxSplit::kSurfaceArea, &pool));
    for (BoxSplit split : {BoxSplit::kSurfaceArea, BoxSplit::kMedian})
        expectSame(buildWith(random, split), buildWith(random, split, &pool));
    expectWellFormed(random, buildWith(random, BoxSplit::kSurfaceArea, &pool), 4);
}

TEST(BoxHierarchy, EmptySceneAndBadConfig) {
    Scene empty;
    auto h = BoxHierarchy::build(empty);
    ASSERT_TRUE(h.isOk());
    EXPECT_EQ(h->nodeCount(), 0u);
    auto camera = Camera::create({});
    ASSERT_TRUE(camera.isOk());
    HoleFlags flags;
    HoleQueryStats stats;
    h->markHole(*camera, {0, 0, 8, 8}, &flags, &stats);
    EXPECT_EQ(stats.nodesTested, 0u);
    BoxHierarchyConfig config;
    config.leafSize = 0;
    EXPECT_EQ(BoxHierarchy::build(empty, config).status().code(), ErrorCode::kInvalidArgument);
}

// The separating test's near-plane rules: wholly nearer than the near plane is a miss (clipped
// away), straddling it is a "may cover" even when the visible corners project far away.
TEST(BoxHierarchy, NearPlaneIsTreatedConservatively) {
    CameraDesc desc;
    desc.eyePos = {0, 0, 0};
    desc.targetPos = {0, 0, -1};
    desc.nearPlane = 1.0f;
    desc.width = 100;
    desc.height = 100;
    auto camera = Camera::create(desc);
    ASSERT_TRUE(camera.isOk());
    PixelRect centre{45, 45, 55, 55};
    // In front, projecting to the centre; and the same shifted far to the right: a miss.
    EXPECT_TRUE(triangleMayCoverRect(*camera, {-0.1f, -0.1f, -5}, {0.1f, -0.1f, -5}, {0, 0.1f, -5},
                                     centre));
    EXPECT_FALSE(
        triangleMayCoverRect(*camera, {2.9f, -0.1f, -5}, {3.1f, -0.1f, -5}, {3, 0.1f, -5}, centre));
    // Wholly between the eye and the near plane, or behind the eye: clipped, a miss.
    EXPECT_FALSE(triangleMayCoverRect(*camera, {-0.1f, -0.1f, -0.5f}, {0.1f, -0.1f, -0.5f},
                                      {0, 0.1f, -0.5f}, centre));
    EXPECT_FALSE(triangleMayCoverRect(*camera, {-1, -1, 3}, {1, -1, 3}, {0, 1, 3}, centre));
    // From behind the eye to far right in front: the visible part may sweep across the centre.
    EXPECT_TRUE(triangleMayCoverRect(*camera, {3, -0.1f, -5}, {3, 0.1f, -5}, {-3, 0, 2}, centre));
    EXPECT_TRUE(boxMayCoverRect(*camera, Aabb{{2, -1, -5}, {3, 1, 2}}, centre));
    EXPECT_FALSE(boxMayCoverRect(*camera, Aabb{{2, -1, -5}, {3, 1, -2}}, centre));
}

// Conservative: on random scenes, cameras and rectangles, no triangle whose (near-clipped)
// surface reaches the rectangle is ever flagged negative, nor failed by the separating test;
// and the flags are exactly the paper's rule applied node by node.
TEST(BoxHierarchy, NeverRejectsATriangleThatReachesTheRectangle) {
    std::mt19937 rng(2);
    size_t overlapping = 0, rejected = 0;
    HoleFlags flags;  // reused across scenes and queries
    for (int s = 0; s < 4; ++s) {
        Scene scene = randomTriangles(&rng, 400);
        auto h = BoxHierarchy::build(scene);
        ASSERT_TRUE(h.isOk());
        for (int q = 0; q < 25; ++q) {
            Camera camera = randomCamera(&rng);
            PixelRect rect = randomRect(&rng);
            HoleQueryStats stats;
            h->markHole(camera, rect, &flags, &stats);
            std::vector<bool> expected = referenceFlags(*h, camera, rect, scene.triangleCount());
            size_t positive = 0;
            for (uint32_t t = 0; t < scene.triangleCount(); ++t) {
                ASSERT_EQ(flags.mayCover(t), bool(expected[t])) << "triangle " << t;
                positive += flags.mayCover(t);
                auto tri = corners(scene, t);
                if (sampledOverlap(camera, tri, rect)) {
                    ++overlapping;
                    EXPECT_TRUE(flags.mayCover(t)) << "scene " << s << " query " << q;
                    EXPECT_TRUE(triangleMayCoverRect(camera, tri[0], tri[1], tri[2], rect));
                } else if (!flags.mayCover(t)) {
                    ++rejected;
                }
            }
            EXPECT_EQ(stats.trianglesPositive, positive);
        }
    }
    // Neither side vacuous.
    EXPECT_GT(overlapping, 1000u);
    EXPECT_GT(rejected, 10000u);
}

// The frustum's plane tests never reject a triangle whose sampled surface reaches the rectangle,
// in markHole or on its own, and flag no more than the projected-box tests overall.
TEST(BoxHierarchy, FrustumTestsAreConservativeAndTighter) {
    std::mt19937 rng(5);
    size_t overlapping = 0, frustumPositive = 0, projectedPositive = 0;
    HoleFlags flags, projected;
    for (int s = 0; s < 4; ++s) {
        Scene scene = randomTriangles(&rng, 400);
        auto h = BoxHierarchy::build(scene);
        ASSERT_TRUE(h.isOk());
        for (int q = 0; q < 25; ++q) {
            Camera camera = randomCamera(&rng);
            PixelRect rect = randomRect(&rng);
            RectFrustum frustum(camera, rect);
            h->markHole(frustum, &flags);
            h->markHole(camera, rect, &projected);
            for (uint32_t t = 0; t < scene.triangleCount(); ++t) {
                auto tri = corners(scene, t);
                frustumPositive += flags.mayCover(t);
                projectedPositive += projected.mayCover(t);
                if (!sampledOverlap(camera, tri, rect)) continue;
                ++overlapping;
                EXPECT_TRUE(flags.mayCover(t)) << "scene " << s << " query " << q;
                EXPECT_TRUE(frustum.mayCoverPoints(tri));
                Aabb box;
                for (const Vec3& v : tri) box.extend(v);
                EXPECT_TRUE(frustum.mayCoverBox(box));
            }
        }
    }
    EXPECT_GT(overlapping, 1000u);
    EXPECT_LE(frustumPositive, projectedPositive);
}

// The office with its box hierarchy, seen from its default viewpoint.
struct OfficeView {
    Scene scene;
    BoxHierarchy hierarchy;
    std::optional<Camera> camera;  // empty when any step failed
};

OfficeView officeView(int rooms, int width, int height) {
    OfficeView view;
    auto scene = generateOffice(rooms);
    EXPECT_TRUE(scene.isOk());
    if (!scene) return view;
    view.scene = std::move(*scene);
    auto hierarchy = BoxHierarchy::build(view.scene);
    auto camera = cameraAt(view.scene, defaultViewpoint(view.scene), width, height);
    EXPECT_TRUE(hierarchy.isOk() && camera.isOk());
    if (!hierarchy || !camera) return view;
    view.hierarchy = std::move(*hierarchy);
    view.camera = *camera;
    return view;
}

// A 32x32 hole in the middle of the office's default view: most of the scene is rejected, most
// of it by whole subtrees.
TEST(BoxHierarchy, SmallHoleRejectsMostOfTheOffice) {
    OfficeView office = officeView(4, 1280, 720);
    ASSERT_TRUE(office.camera);
    HoleFlags flags;
    HoleQueryStats stats;
    office.hierarchy.markHole(*office.camera, {624, 344, 656, 376}, &flags, &stats);
    EXPECT_GT(stats.trianglesPositive, 0u);
    EXPECT_LT(double(stats.trianglesPositive), 0.01 * double(office.scene.triangleCount()));
    EXPECT_LT(double(stats.nodesTested), 0.05 * double(office.hierarchy.nodeCount()));
}

// Surface-area splits pay on the office: over small holes across its default view, the query
// tests fewer nodes and flags fewer triangles than with median splits.
TEST(BoxHierarchy, SurfaceAreaSplitsTestFewerNodesOnTheOffice) {
    OfficeView office = officeView(4, 1280, 720);
    ASSERT_TRUE(office.camera);
    BoxHierarchy median = buildWith(office.scene, BoxSplit::kMedian);
    HoleFlags flags;
    size_t nodes[2] = {0, 0}, triangles[2] = {0, 0};
    for (int y = 8; y < 720; y += 48)
        for (int x = 8; x < 1280; x += 48) {
            const PixelRect rect{x, y, x + 16, y + 4};  // a sliver's size
            int k = 0;
            for (const BoxHierarchy* h : {&median, &office.hierarchy}) {
                HoleQueryStats stats;
                h->markHole(RectFrustum(*office.camera, rect), &flags, &stats);
                nodes[k] += stats.nodesTested;
                triangles[k++] += stats.trianglesPositive;
            }
        }
    EXPECT_LT(double(nodes[1]), 0.8 * double(nodes[0]));
    EXPECT_LT(triangles[1], triangles[0]);
}

// Flags reused over a sequence of queries equal those of a fresh flag set per query.
TEST(BoxHierarchy, ReusedFlagsEqualFreshOnes) {
    OfficeView office = officeView(2, 640, 360);
    ASSERT_TRUE(office.camera);
    std::mt19937 rng(4);
    std::uniform_int_distribution<int> x(0, 600), y(0, 330), side(1, 40);
    HoleFlags reused;
    size_t changed = 0;
    std::vector<bool> previous(office.scene.triangleCount(), false);
    for (int q = 0; q < 20; ++q) {
        PixelRect rect{x(rng), y(rng), 0, 0};
        rect.x1 = rect.x0 + side(rng);
        rect.y1 = rect.y0 + side(rng);
        HoleFlags fresh;
        office.hierarchy.markHole(*office.camera, rect, &reused);
        office.hierarchy.markHole(*office.camera, rect, &fresh);
        for (uint32_t t = 0; t < office.scene.triangleCount(); ++t) {
            ASSERT_EQ(reused.mayCover(t), fresh.mayCover(t)) << "query " << q;
            changed += reused.mayCover(t) != previous[t];
            previous[t] = reused.mayCover(t);
        }
        for (size_t n = 0; n < office.hierarchy.nodeCount(); ++n)
            ASSERT_EQ(reused.nodePositive(n), fresh.nodePositive(n));
    }
    EXPECT_GT(changed, 100u);  // the queries differ, so stale flags would show
}

}  // namespace
}  // namespace plx::scene
