// The reproject method end to end (Fu, Bao, Peng): holes filled by their polygon or by the BSP
// search, against the full render of the same eye.

#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include <plx/core/cpu.h>
#include <plx/scene/generators.h>
#include <plx/scene/primitives.h>
#include <plx/stereo/fill.h>
#include <plx/stereo/stereo.h>
#include <plx/stereo/unseen.h>

#include "../src/box_search.h"
#include "../src/polygon_spans.h"

namespace plx::stereo {
namespace {

Camera lookAt(Vec3 eye, Vec3 target, int w, int h, float nearPlane = 0.1f) {
    CameraDesc d;
    d.eyePos = eye;
    d.targetPos = target;
    d.width = w;
    d.height = h;
    d.fovYDegrees = 60.0f;
    d.nearPlane = nearPlane;
    d.farPlane = 100.0f;
    return *Camera::create(d);
}

std::vector<StereoRigDesc> allRigs(float separation = 0.065f) {
    std::vector<StereoRigDesc> rigs;
    for (StereoRigType type : {StereoRigType::kConverged, StereoRigType::kParallel}) {
        for (Eye eye : {Eye::kLeft, Eye::kRight}) {
            StereoRigDesc d;
            d.type = type;
            d.separation = separation;
            d.firstEye = eye;
            rigs.push_back(d);
        }
    }
    return rigs;
}

std::string rigName(const StereoRigDesc& d) {
    return std::string(d.type == StereoRigType::kConverged ? "converged" : "parallel") +
           (d.firstEye == Eye::kLeft ? " left first" : " right first");
}

// A reproject pair and the full pair of the same rig, both with depth and IDs.
struct Pairs {
    StereoFrame reprojected, full;
    StereoFrameStats stats;
    Eye second = Eye::kRight;

    Pairs(const scene::Scene& s, const StereoRig& rig, const StereoOptions& base = {}) {
        auto r = std::move(StereoRenderer::create({2})).value();
        StereoOptions options = base;
        options.method = Method::kFull;
        r->renderPair(s, rig, options, &full);
        options.method = Method::kReproject;
        PLX_CHECK(r->prepareReprojection(s, options.fillSearch).isOk());
        stats = r->renderPair(s, rig, options, &reprojected);
        second = rig.secondEye();
    }
    const raster::FrameBuffers& mine() const { return reprojected.eye(second); }
    const raster::FrameBuffers& theirs() const { return full.eye(second); }
};

// Every hole pixel got a class; disocclusion pixels (drawn or empty) equal the full render;
// expansion pixels too when `exactExpansion`. Returns the disocclusion pixels drawn.
int64_t expectHolesFilledLikeFull(const Pairs& p, bool exactExpansion, const std::string& what) {
    const Image<uint8_t>& cls = p.reprojected.holeClass;
    const raster::FrameBuffers &a = p.mine(), &b = p.theirs();
    int64_t holes = 0, drawn = 0, mismatches = 0;
    for (int y = 0; y < cls.height(); ++y) {
        for (int x = 0; x < cls.width(); ++x) {
            uint8_t c = cls.at(x, y);
            EXPECT_LE(c, 4) << what;
            if (c == 0 || c == uint8_t(PixelSource::kUnseen)) continue;
            ++holes;
            if (c == uint8_t(PixelSource::kExpansion) || c == uint8_t(PixelSource::kDisocclusion)) {
                EXPECT_NE(a.id.at(x, y), 0u) << what;
            }
            if (c == uint8_t(PixelSource::kDisocclusion)) ++drawn;
            if (c == uint8_t(PixelSource::kDisocclusionEmpty)) {
                EXPECT_EQ(a.id.at(x, y), 0u) << what;
            }
            if (c == uint8_t(PixelSource::kExpansion) && !exactExpansion) continue;
            bool same = a.id.at(x, y) == b.id.at(x, y) && a.color.at(x, y) == b.color.at(x, y) &&
                        a.depth.at(x, y) == b.depth.at(x, y);
            if (!same && mismatches++ < 5)
                ADD_FAILURE() << what << ": pixel " << x << "," << y << " class " << int(c)
                              << " id " << a.id.at(x, y) << " full " << b.id.at(x, y);
        }
    }
    EXPECT_EQ(holes, p.stats.holePixels) << what;
    EXPECT_EQ(p.stats.expansionPixels + p.stats.disocclusionPixels, p.stats.holePixels) << what;
    return drawn;
}

TEST(Fill, ZeroSeparationGivesTheFirstEyeExactly) {
    scene::Scene s = *scene::generateOffice(2);
    Camera center = *scene::cameraAt(s, s.viewpoints.front(), 160, 120);
    for (StereoRigDesc desc : allRigs(0.0f)) {
        StereoRig rig = *StereoRig::create(center, desc);
        Pairs p(s, rig);
        const raster::FrameBuffers& first = p.reprojected.eye(desc.firstEye);
        EXPECT_TRUE(p.mine().color == first.color) << rigName(desc);
        EXPECT_TRUE(p.mine().depth == first.depth) << rigName(desc);
        EXPECT_TRUE(p.mine().id == first.id) << rigName(desc);
        EXPECT_EQ(p.stats.holePixels, 0) << rigName(desc);
        EXPECT_TRUE(p.reprojected.holeClass == Image<uint8_t>(160, 120, 0));
    }
}

// A wall at the convergence distance has zero disparity in the converged rig: nothing moves.
TEST(Fill, FrontoParallelPlaneAtConvergenceHasNoHole) {
    scene::Scene s;
    scene::Mesh m;
    Vec2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    scene::appendQuad(&m, {-20, -20, -3}, {40, 0, 0}, {0, 40, 0}, uv);
    s.meshes.push_back(std::move(m));
    ASSERT_TRUE(s.finalize().isOk());
    for (StereoRigDesc desc : allRigs()) {
        if (desc.type != StereoRigType::kConverged) continue;
        desc.convergence = 3.0f;
        StereoRig rig = *StereoRig::create(lookAt({0, 0, 0}, {0, 0, -1}, 96, 64), desc);
        Pairs p(s, rig);
        EXPECT_EQ(p.stats.holePixels, 0) << rigName(desc);
        EXPECT_TRUE(p.mine().id == p.theirs().id) << rigName(desc);
    }
}

// Triangles of one surface: the two halves of a quad (a shared edge), two quads of one plane
// (a T-junction, no shared edge), not a quad and a box face, nor a triangle with itself.
TEST(Fill, TrianglesOfOneSurface) {
    scene::Scene s;
    scene::Mesh wall, box;
    Vec2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    scene::appendQuad(&wall, {0, 0, -5}, {2, 0, 0}, {0, 2, 0}, uv);     // triangles 0, 1
    scene::appendQuad(&wall, {2, 0, -5}, {2, 0, 0}, {0, 1, 0}, uv);     // 2, 3: same plane
    scene::appendQuad(&wall, {2, 1, -5.5f}, {2, 0, 0}, {0, 1, 0}, uv);  // 4, 5: parallel, behind
    box.materialIndex = 0;
    scene::appendBox(&box, {0, 0, -3}, {0.5f, 0.5f, 0.5f}, 0.0f);
    s.meshes = {wall, box};
    s.materials = {{"m", {0.5f, 0.5f, 0.5f, 1}, -1}};
    ASSERT_TRUE(s.finalize().isOk());
    const uint32_t boxFirst = uint32_t(s.firstTriangle(1));
    EXPECT_TRUE(trianglesOfOneSurface(s, 0, 1));
    EXPECT_TRUE(trianglesOfOneSurface(s, 1, 0));
    EXPECT_TRUE(trianglesOfOneSurface(s, 0, 2));
    EXPECT_TRUE(trianglesOfOneSurface(s, 3, 1));
    EXPECT_FALSE(trianglesOfOneSurface(s, 0, 4));
    EXPECT_FALSE(trianglesOfOneSurface(s, 2, 5));
    EXPECT_FALSE(trianglesOfOneSurface(s, 0, boxFirst));
    EXPECT_FALSE(trianglesOfOneSurface(s, 0, 0));
    EXPECT_FALSE(trianglesOfOneSurface(s, 0, uint32_t(s.triangleCount())));
}

// The four-wide copy of the box hierarchy holds every leaf once, each lane with its binary node's
// box (so every triangle's corners inside it), inner lanes pointing further down the array; a
// hierarchy that is one leaf is one node of one lane.
TEST(Fill, FourWideBoxesHoldEveryLeafOnce) {
    scene::Scene one;
    scene::Mesh quad;
    Vec2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    scene::appendQuad(&quad, {-1, -1, -3}, {2, 0, 0}, {0, 2, 0}, uv);
    one.meshes = {quad};
    one.materials = {{"quad", {0.7f, 0.7f, 0.6f, 1}, -1}};
    ASSERT_TRUE(one.finalize().isOk());
    for (int rooms : {0, 1, 6}) {
        const scene::Scene s = rooms == 0 ? one : *scene::generateOffice(rooms);
        const FillScene fill = *buildFillScene(s);
        const std::vector<WideBoxNode>& wide = fill.wideBoxes;
        ASSERT_FALSE(wide.empty());
        if (rooms == 0) {
            ASSERT_EQ(wide.size(), 1u);
            EXPECT_EQ(wide[0].lanes, 1);
            EXPECT_EQ(wide[0].count[0], 2);
        }
        std::vector<int> seen(fill.boxes.triangles().size(), 0);
        for (size_t n = 0; n < wide.size(); ++n) {
            const WideBoxNode& node = wide[n];
            ASSERT_GE(node.lanes, 1);
            ASSERT_LE(node.lanes, 4);
            for (size_t k = 0; k < node.lanes; ++k) {
                if (node.count[k] == 0) {
                    EXPECT_GT(node.first[k], n);
                    EXPECT_LT(node.first[k], wide.size());
                    continue;
                }
                for (uint32_t e = node.first[k]; e < node.first[k] + node.count[k]; ++e) {
                    ASSERT_LT(e, seen.size());
                    ++seen[e];
                    for (const Vec3& p : fill.boxCorners.triangle(e)) {
                        EXPECT_TRUE(p.x >= node.loX[k] && p.x <= node.hiX[k] &&
                                    p.y >= node.loY[k] && p.y <= node.hiY[k] &&
                                    p.z >= node.loZ[k] && p.z <= node.hiZ[k]);
                    }
                }
            }
        }
        for (int count : seen) EXPECT_EQ(count, 1) << rooms << " rooms";
    }
}

// The four-wide projection pre-test rejects only triangles the scalar pre-test rejects over the
// whole box, never one reaching before the near plane, and most of those the scalar one rejects.
TEST(Fill, FourWideProjectionPreTestAgreesWithTheScalarPreTest) {
    const Camera camera = lookAt({0.0f, 0.0f, 5.0f}, {0.0f, 0.0f, 0.0f}, 64, 48);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> xy(-4.0f, 4.0f), z(-4.0f, 5.5f);
    std::uniform_int_distribution<int> column(0, 56), row(0, 40), side(1, 8);
    constexpr size_t kTriangles = 4000;
    LeafCorners corners;
    for (size_t k = 0; k < 3; ++k) {
        for (auto* axis : {&corners.x[k], &corners.y[k], &corners.z[k]}) {
            axis->resize(kTriangles + LeafCorners::kPadding);
        }
    }
    for (size_t i = 0; i < kTriangles + LeafCorners::kPadding; ++i) {
        for (size_t k = 0; k < 3; ++k) {
            corners.x[k][i] = xy(rng);
            corners.y[k][i] = xy(rng);
            corners.z[k][i] = z(rng);
        }
    }
    int rejected = 0, scalarRejected = 0, nearRejected = 0;
    for (size_t entry = 0; entry < kTriangles; entry += 4) {
        const int x0 = column(rng), y0 = row(rng);
        const scene::PixelRect box{x0, y0, x0 + side(rng), y0 + side(rng)};
        std::vector<raster::PixelSpan> spans;
        for (int y = box.y0; y < box.y1; ++y) spans.push_back({y, box.x0, box.x1 - 1});
        const FourTriangles four = projectFourTriangles(camera, corners, entry, box);
        for (size_t k = 0; k < 4; ++k) {
            const std::array<Vec3, 3> triangle = corners.triangle(entry + k);
            const bool scalarMiss = !polygonMayCoverSpans(camera, triangle, spans, box);
            const bool fourWideMiss = (four.missBox >> k & 1u) != 0;
            scalarRejected += scalarMiss;
            rejected += fourWideMiss;
            EXPECT_TRUE(!fourWideMiss || scalarMiss) << "triangle " << entry + k;
            bool beforeNear = false;
            for (const Vec3& p : triangle)
                beforeNear |= !((camera.clipFromWorld() * Vec4(p, 1.0f)).w >= 0.1f);
            nearRejected += beforeNear && fourWideMiss;
        }
    }
    EXPECT_EQ(nearRejected, 0);
    EXPECT_GT(scalarRejected, int(kTriangles) / 4);
    EXPECT_GE(rejected, scalarRejected * 9 / 10);
}

// Boxes in front of a wall and a floor: the walls' disocclusions beside every box are drawn from
// the wall and floor behind them, the polygon the full render shows there.
TEST(Fill, BoxesInFrontOfWallsGetTheFullRendersPolygons) {
    scene::Scene s;
    scene::Mesh walls, boxes;
    Vec2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    scene::appendQuad(&walls, {-8, -1, -7}, {16, 0, 0}, {0, 8, 0}, uv);
    scene::appendQuad(&walls, {-8, -1, 0}, {16, 0, 0}, {0, 0, -7}, uv);
    for (int i = 0; i < 5; ++i)
        scene::appendBox(&boxes, {-2.0f + 1.0f * i, -0.5f + 0.2f * i, -2.5f - 0.6f * i},
                         {0.25f, 0.4f, 0.25f}, 0.3f * i);
    boxes.materialIndex = 1;
    s.meshes = {walls, boxes};
    s.materials = {{"wall", {0.7f, 0.7f, 0.6f, 1}, -1}, {"box", {0.8f, 0.3f, 0.2f, 1}, -1}};
    ASSERT_TRUE(s.finalize().isOk());
    for (StereoRigDesc desc : allRigs(0.2f)) {
        StereoRig rig = *StereoRig::create(lookAt({0, 0.5f, 0}, {0, 0, -3}, 160, 120), desc);
        Pairs p(s, rig);
        EXPECT_GT(p.stats.disocclusionHoles, 0u) << rigName(desc);
        EXPECT_GT(expectHolesFilledLikeFull(p, true, rigName(desc)), 0) << rigName(desc);
    }
}

// A wall, and poles just outside both image borders of a 96x64 view down -z from the origin, near
// the camera. Their IDs start at firstPoleId.
struct PoleScene {
    scene::Scene s;
    uint32_t firstPoleId = 0;
    PoleScene() {
        scene::Mesh wall, poles;
        Vec2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
        scene::appendQuad(&wall, {-10, -5, -8}, {20, 0, 0}, {0, 10, 0}, uv);
        // The half-width of the centre view at depth z is tan(30 deg) * 96 / 64 * z = 0.866 z;
        // the eyes' views differ from it by the rig, so poles stand at several depths and offsets.
        for (float z : {1.0f, 1.7f, 2.5f})
            for (float side : {-1.0f, 1.0f})
                for (float beyond : {0.02f, 0.09f, 0.2f})
                    scene::appendCylinder(&poles, {side * (0.866f * z + beyond), -3, -z}, 0.02f, 6,
                                          8);
        poles.materialIndex = 1;
        s.meshes = {wall, poles};
        s.materials = {{"wall", {0.5f, 0.6f, 0.7f, 1}, -1}, {"pole", {0.9f, 0.9f, 0.1f, 1}, -1}};
        PLX_CHECK(s.finalize().isOk());
        firstPoleId = uint32_t(s.firstTriangle(1)) + 1;
    }
    // The reproject and full pairs of `desc` converged at `convergence`, their holes checked.
    Pairs pairs(StereoRigDesc desc, float convergence) const {
        desc.convergence = convergence;
        Pairs p(s, *StereoRig::create(lookAt({0, 0, 0}, {0, 0, -1}, 96, 64), desc));
        expectHolesFilledLikeFull(p, true, rigName(desc));
        return p;
    }
};

// The second eye sees one of the poles enter at its border, in front of everything there. The
// root-started search finds it.
TEST(Fill, PoleEnteringAtTheBorderIsFound) {
    const PoleScene poles;
    const uint32_t firstPoleId = poles.firstPoleId;
    for (StereoRigDesc desc : allRigs(0.2f)) {
        // Convergence nearer than every surface, so that the whole image moves and a hole opens
        // at the border as in the parallel rig. (Converged at the wall, the wall would not move
        // and would cover the border columns: a pole entering over a surface that reprojects
        // there leaves no hole; the test below.)
        const Pairs p = poles.pairs(desc, 0.5f);
        int64_t polePixels = 0;
        for (size_t i = 0; i < p.mine().id.pixelCount(); ++i)
            if (p.reprojected.holeClass.data()[i] == uint8_t(PixelSource::kDisocclusion) &&
                p.mine().id.data()[i] >= firstPoleId)
                ++polePixels;
        EXPECT_GT(polePixels, 0) << rigName(desc);
    }
}

// The poles of the test above with the rig converged at the wall, which then covers the border
// columns: a pole entering there hides wall pixels that landed, and no hole opens over them.
// drawUnseenOccluders (unseen.h) draws it there as the full render does.
TEST(Fill, PoleOutsideTheFirstViewHidesWhatLanded) {
    const PoleScene poles;
    const uint32_t firstPoleId = poles.firstPoleId;
    for (StereoRigDesc desc : allRigs(0.2f)) {
        const Pairs p = poles.pairs(desc, 8.0f);
        int64_t unseen = 0, polePixels = 0, poleMissed = 0;
        for (size_t i = 0; i < p.mine().id.pixelCount(); ++i) {
            const uint32_t mine = p.mine().id.data()[i], full = p.theirs().id.data()[i];
            if (p.reprojected.holeClass.data()[i] == uint8_t(PixelSource::kUnseen)) {
                ++unseen;
                EXPECT_EQ(mine, full) << rigName(desc) << " pixel " << i;
                EXPECT_GE(mine, firstPoleId) << rigName(desc) << " pixel " << i;
            }
            if (full >= firstPoleId) ++polePixels, poleMissed += mine != full;
        }
        EXPECT_GT(unseen, 0) << rigName(desc);
        EXPECT_GE(p.stats.unseenPixels, unseen) << rigName(desc);
        // Without the pass every pole pixel is missed; with it none are here, and at most a
        // landed edge pixel rounding to the other column could be.
        EXPECT_LE(poleMissed, polePixels / 50)
            << rigName(desc) << ": " << poleMissed << " of " << polePixels;
    }
}

// The parallel rig's unseen wedge runs deep (to clip w 2 |a|, 22 here): poles stand in it from
// 4 to 19 units away, behind a wall at 3 that hides them from the second eye. The walk goes
// nearest box first and opens no box the wall already hides (unseen.h): without the wall it
// reaches the poles' triangles, with it not one, and the pixels it writes are the full render's.
TEST(Fill, UnseenWalkEndsAtTheWallThatHidesTheRest) {
    for (bool withWall : {false, true}) {
        scene::Scene s;
        scene::Mesh wall, poles;
        Vec2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
        scene::appendQuad(&wall, {-10, -5, -3}, {20, 0, 0}, {0, 10, 0}, uv);
        // The half-width of the view at depth z is 0.866 z (PoleScene): each pole stands
        // between the two eyes' side planes there, in the wedge of either eye first.
        for (int i = 0; i < 16; ++i) {
            const float z = 4.0f + float(i);
            for (float side : {-1.0f, 1.0f})
                scene::appendCylinder(&poles, {side * 0.866f * z, -3, -z}, 0.02f, 6, 8);
        }
        poles.materialIndex = 1;
        s.meshes = withWall ? std::vector<scene::Mesh>{poles, wall} : std::vector{poles};
        s.materials = {{"wall", {0.5f, 0.6f, 0.7f, 1}, -1}, {"pole", {0.9f, 0.9f, 0.1f, 1}, -1}};
        ASSERT_TRUE(s.finalize().isOk());
        const FillScene fill = *buildFillScene(s);
        auto renderer = std::move(raster::Renderer::create({1})).value();
        for (StereoRigDesc desc : allRigs(0.2f)) {
            if (desc.type != StereoRigType::kParallel) continue;
            const std::string what = rigName(desc) + (withWall ? ", wall" : ", no wall");
            const StereoRig rig = *StereoRig::create(lookAt({0, 0, 0}, {0, 0, -1}, 96, 64), desc);
            raster::FrameBuffers full, mine;
            full.resize(96, 64), mine.resize(96, 64);
            renderer->render(s, rig.second(), {}, full.targets());
            constexpr uint32_t kUnwritten = ~0u;
            mine.id.view().fill(kUnwritten);
            UnseenScratch scratch;
            const UnseenStats st =
                drawUnseenOccluders(s, fill, rig.first(), rig.second(), disparityLine(rig), {},
                                    mine.targets(), {}, &scratch);
            // 16 poles of 32 triangles stand in the wedge: without the wall the walk reaches a
            // quarter of their triangles or more (nearer poles hide some farther ones), with it
            // the wall's two at most.
            if (withWall)
                EXPECT_LE(st.trianglesReached, s.meshes[1].triangleCount()) << what;
            else
                EXPECT_GE(st.trianglesReached, 16u * 8u) << what;
            int64_t written = 0;
            for (size_t i = 0; i < mine.id.pixelCount(); ++i) {
                if (mine.id.data()[i] == kUnwritten) continue;
                ++written;
                EXPECT_EQ(mine.id.data()[i], full.id.data()[i]) << what << " pixel " << i;
            }
            EXPECT_EQ(written, st.pixels) << what;
            EXPECT_GT(written, 0) << what;
        }
    }
}

// A panel the first eye sees edge-on and the second more frontally, before a far wall, at a wide
// separation: the panel's pixels spread apart in the second eye, and wall pixels land between
// them. The row pass takes those off (reproject.h, gaps), so the fill draws the panel there as
// the full render shows it, not the wall through it.
TEST(Fill, SpreadSurfaceHidesTheWallBehindIt) {
    scene::Scene s;
    scene::Mesh wall, panel;
    Vec2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    scene::appendQuad(&wall, {-10, -5, -8}, {20, 0, 0}, {0, 10, 0}, uv);
    scene::appendQuad(&panel, {-0.1f, -0.5f, -1.5f}, {0.4f, 0, -2.0f}, {0, 1, 0}, uv);
    panel.materialIndex = 1;
    s.meshes = {wall, panel};
    s.materials = {{"wall", {0.5f, 0.6f, 0.7f, 1}, -1}, {"panel", {0.9f, 0.5f, 0.1f, 1}, -1}};
    ASSERT_TRUE(s.finalize().isOk());
    const uint32_t firstPanelId = uint32_t(s.firstTriangle(1)) + 1;
    for (StereoRigDesc desc : allRigs(0.5f)) {
        if (desc.firstEye != Eye::kLeft) continue;  // the panel faces the right eye
        Pairs p(s, *StereoRig::create(lookAt({0, 0, 0}, {0, 0, -1}, 160, 120), desc));
        expectHolesFilledLikeFull(p, true, rigName(desc));
        int64_t panelPixels = 0, wallShown = 0;
        for (size_t i = 0; i < p.mine().id.pixelCount(); ++i) {
            if (p.theirs().id.data()[i] < firstPanelId) continue;
            ++panelPixels;
            wallShown += p.mine().id.data()[i] != 0 && p.mine().id.data()[i] < firstPanelId;
        }
        // Without the gaps closed the wall shows through 78% (converged) and 75% (parallel) of
        // the panel; with them, but not beyond their ends, 16% and none, along the panel's near
        // edge, which the first eye places to a pixel and the spread widens; with them closed
        // beyond their ends too, 2.3% and none.
        EXPECT_GT(panelPixels, 500) << rigName(desc);
        EXPECT_LE(wallShown, panelPixels / 25) << rigName(desc) << " of " << panelPixels;
    }
}

// The office with every rig, either eye first, direct form and table: holes all filled, the
// disocclusions as the full render, and 99% of the second eye identical with flat shading.
TEST(Fill, OfficeSecondEyeIsAlmostTheFullRender) {
    scene::Scene s = *scene::generateOffice(4);
    Camera center = *scene::cameraAt(s, s.viewpoints.front(), 640, 480);
    for (StereoRigDesc desc : allRigs()) {
        for (bool lut : {false, true}) {
            StereoRig rig = *StereoRig::create(center, desc);
            StereoOptions options;
            options.reprojectWithLut = lut;
            Pairs p(s, rig, options);
            std::string what = rigName(desc) + (lut ? " lut" : " direct");
            EXPECT_GT(p.stats.holePixels, 0) << what;
            expectHolesFilledLikeFull(p, false, what);
            SecondEyeQuality q = compareSecondEye(p.mine(), p.theirs(), {});
            EXPECT_LE(q.differingFraction, 0.01) << what;
            EXPECT_GE(q.psnrDb, 38.0) << what;
            EXPECT_EQ(p.stats.secondEyeTriangles, p.stats.fillPolygonsDrawn);
        }
    }
}

// The surrounding polygons first (beyond the paper, approximate): every hole pixel still gets a
// class, at most 1% of the office's second eye differs from the full render and its PSNR stays
// within 3 dB of the exact fill's (it falls to 37.8-37.9 dB here, under the 38 dB the default
// meets: the reason it is an option), and the search runs for fewer box nodes.
TEST(Fill, SurroundingPolygonsFirstStayCloseWithLessSearch) {
    scene::Scene s = *scene::generateOffice(4);
    Camera center = *scene::cameraAt(s, s.viewpoints.front(), 640, 480);
    for (StereoRigDesc desc : allRigs()) {
        StereoRig rig = *StereoRig::create(center, desc);
        StereoOptions exactOptions, fastOptions;
        fastOptions.reprojectSurroundingFirst = true;
        Pairs exact(s, rig, exactOptions), fast(s, rig, fastOptions);
        std::string what = rigName(desc);
        ASSERT_GT(fast.stats.disocclusionHoles, 0u) << what;
        for (size_t i = 0; i < fast.reprojected.holeClass.pixelCount(); ++i)
            ASSERT_EQ(fast.reprojected.holeClass.data()[i] == uint8_t(PixelSource::kReprojected),
                      exact.reprojected.holeClass.data()[i] == uint8_t(PixelSource::kReprojected))
                << what;
        SecondEyeQuality q = compareSecondEye(fast.mine(), fast.theirs(), {});
        SecondEyeQuality qExact = compareSecondEye(exact.mine(), exact.theirs(), {});
        EXPECT_LE(q.differingFraction, 0.01) << what;
        EXPECT_GE(q.psnrDb, qExact.psnrDb - 3.0) << what;
        EXPECT_LE(q.psnrDb, qExact.psnrDb) << what;
        EXPECT_LT(fast.stats.fillNodesVisited, exact.stats.fillNodesVisited) << what;
    }
}

// A second eye moved from a rendered first eye, its holes found and classified as the pair does
// them; fillHoles is left to the test.
struct MovedSecondEye {
    raster::FrameBuffers eye;
    Image<uint8_t> mask, classes;
    HoleSet holes;

    MovedSecondEye(const scene::Scene& s, const StereoRig& rig, const raster::FrameBuffers& first) {
        const int w = first.color.width(), h = first.color.height();
        eye.resize(w, h);
        mask.resize(w, h);
        classes = Image<uint8_t>(w, h, 0);
        PLX_CHECK(reproject({first.color.view(), first.depth.view(), first.id.view()},
                            disparityLine(rig), targets())
                      .isOk());
        HoleScratch scratch;
        findHoles(std::as_const(mask).view(), HoleConnectivity::k8, scratch, holes);
        // Cracks over triangles of one surface are expansion holes too.
        classifyHoles(std::as_const(eye.id).view(), holes, [&s](uint32_t a, uint32_t b) {
            return trianglesOfOneSurface(s, a - 1, b - 1);
        });
    }
    SecondEyeTargets targets() {
        return {eye.color.view(), eye.depth.view(), eye.id.view(), mask.view()};
    }
};

// Confetti (small triangles in a plane, apart) before thin rods and a wall: most holes are slivers
// of a few pixels beside the confetti, which the box search walks along their samples' rays, the
// rest by their frustums. Every disocclusion pixel (drawn or empty) equals the full render's, the
// rods' too, and the BSP search, which walks no rays, fills the same frame.
TEST(Fill, SmallPiecesSearchedAlongTheirRaysGetTheFullRendersPolygons) {
    scene::Scene s;
    scene::Mesh wall, confetti, rods;
    Vec2 uv[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    scene::appendQuad(&wall, {-3, -2, -6}, {6, 0, 0}, {0, 4, 0}, uv);
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> jitter(-0.05f, 0.05f), x(-2.5f, 2.5f), z(-5.0f, -3.0f);
    // A triangle of about 0.1 (five pixels) every 0.25 in the plane z = -2.
    for (int i = 0; i < 14; ++i) {
        for (int j = 0; j < 10; ++j) {
            const Vec3 c(-1.6f + 0.25f * float(i), -1.1f + 0.25f * float(j), -2.0f);
            for (Vec3 corner :
                 {Vec3(-0.05f, -0.05f, 0), Vec3(0.05f, -0.04f, 0), Vec3(0, 0.05f, 0)}) {
                confetti.positions.push_back(c + corner + Vec3(jitter(rng), jitter(rng), 0));
                confetti.normals.push_back({0, 0, 1});
                confetti.indices.push_back(uint32_t(confetti.positions.size() - 1));
            }
        }
    }
    // Rods of one to four pixels' width at their depths: narrower ones, which the first eye's
    // samples may miss, can show in a hole in front of every pixel around it, where the fill's
    // front bound (Fu section 3) does not look.
    for (int i = 0; i < 16; ++i)
        scene::appendCylinder(&rods, {x(rng), -2, z(rng)}, 0.02f + 0.008f * float(i % 4), 4, 6);
    confetti.materialIndex = 1;
    rods.materialIndex = 2;
    s.meshes = {wall, confetti, rods};
    s.materials = {{"wall", {0.6f, 0.6f, 0.7f, 1}, -1},
                   {"confetti", {0.9f, 0.4f, 0.2f, 1}, -1},
                   {"rods", {0.2f, 0.8f, 0.3f, 1}, -1}};
    ASSERT_TRUE(s.finalize().isOk());
    const uint32_t firstRodId = uint32_t(s.firstTriangle(2)) + 1;
    const FillScene boxes = *buildFillScene(s), both = *buildFillScene(s, FillSearch::kBspOrder);
    auto r = std::move(raster::Renderer::create({1})).value();
    for (StereoRigDesc desc : allRigs(0.15f)) {
        StereoRig rig = *StereoRig::create(lookAt({0, 0, 0}, {0, 0, -1}, 200, 150), desc);
        raster::FrameBuffers first, full;
        first.resize(200, 150);
        full.resize(200, 150);
        r->render(s, rig.first(), {}, first.targets());
        r->render(s, rig.second(), {}, full.targets());
        MovedSecondEye a(s, rig, first), b(s, rig, first);
        FillScratch scratch;
        const FillStats st =
            fillHoles(s, boxes, rig.second(), {}, a.holes, a.targets(), a.classes.view(), &scratch);
        FillOptions bsp;
        bsp.search = FillSearch::kBspOrder;
        fillHoles(s, both, rig.second(), bsp, b.holes, b.targets(), b.classes.view(), &scratch);
        const std::string what = rigName(desc);
        size_t pieces = 0;
        for (const Hole& h : a.holes.holes) pieces += h.holeClass == HoleClass::kDisocclusion;
        // 10 to 18 per rig: the row pass's gaps (reproject.h) join some of the confetti's small
        // holes at their edges.
        EXPECT_GT(st.rayPieces, 5u) << what;
        EXPECT_LT(st.rayPieces, pieces) << what;  // larger holes walk their frustums
        int64_t compared = 0, mismatches = 0, rodPixels = 0;
        for (size_t i = 0; i < a.classes.pixelCount(); ++i) {
            const uint8_t c = a.classes.data()[i];
            if (c != uint8_t(PixelSource::kDisocclusion) &&
                c != uint8_t(PixelSource::kDisocclusionEmpty))
                continue;
            ++compared;
            rodPixels += full.id.data()[i] >= firstRodId;
            mismatches += a.eye.id.data()[i] != full.id.data()[i] ||
                          !(a.eye.color.data()[i] == full.color.data()[i]) ||
                          a.eye.depth.data()[i] != full.depth.data()[i];
        }
        EXPECT_GT(compared, 300) << what;
        EXPECT_GT(rodPixels, 5) << what;
        EXPECT_EQ(mismatches, 0) << what;
        EXPECT_TRUE(a.eye.color == b.eye.color) << what;
        EXPECT_TRUE(a.eye.id == b.eye.id) << what;
        EXPECT_TRUE(a.classes == b.classes) << what;
    }
}

// Expansion holes by evaluation or interpolation: both fill every hole pixel; evaluation gives
// the polygon's exact colour, so it is at least as close to the full render. Either fill without
// a hole mask or class image draws the same pixels and counts the same.
TEST(Fill, ExpansionByEvaluationIsAtLeastAsCloseAsInterpolation) {
    scene::Scene s = *scene::generateOffice(2);
    StereoRig rig = *StereoRig::create(*scene::cameraAt(s, s.viewpoints.front(), 320, 240), {});
    FillScene fill = *buildFillScene(s);
    auto r = std::move(raster::Renderer::create({2})).value();
    raster::FrameBuffers first, full;
    first.resize(320, 240);
    full.resize(320, 240);
    r->render(s, rig.first(), {}, first.targets());
    r->render(s, rig.second(), {}, full.targets());
    int64_t differing[2] = {0, 0};
    for (ExpansionFill mode : {ExpansionFill::kEvaluate, ExpansionFill::kInterpolate}) {
        MovedSecondEye second(s, rig, first);
        const Image<uint8_t> holeMask = second.mask;  // fillExpansionHoles clears the mask it fills
        FillOptions options;
        options.expansion = mode;
        FillScratch scratch;
        const Image<uint8_t>& cls = second.classes;
        FillStats st = fillHoles(s, fill, rig.second(), options, second.holes, second.targets(),
                                 second.classes.view(), &scratch);
        EXPECT_EQ(st.expansionPixels + st.disocclusionPixels + st.emptyPixels,
                  second.holes.pixelCount);
        for (size_t i = 0; i < cls.pixelCount(); ++i) {
            EXPECT_EQ(cls.data()[i] != 0, holeMask.data()[i] != 0);
            if (!(second.eye.color.data()[i] == full.color.data()[i]))
                ++differing[mode == ExpansionFill::kInterpolate];
        }

        MovedSecondEye bare(s, rig, first);
        SecondEyeTargets noMask = bare.targets();
        noMask.holeMask = {};
        FillStats bareStats =
            fillHoles(s, fill, rig.second(), options, bare.holes, noMask, {}, &scratch);
        EXPECT_TRUE(bare.eye.color == second.eye.color);
        EXPECT_TRUE(bare.eye.depth == second.eye.depth);
        EXPECT_TRUE(bare.eye.id == second.eye.id);
        EXPECT_TRUE(bare.classes == Image<uint8_t>(320, 240, 0));
        EXPECT_EQ(bareStats.expansionPixels, st.expansionPixels);
        EXPECT_EQ(bareStats.disocclusionPixels, st.disocclusionPixels);
        EXPECT_EQ(bareStats.emptyPixels, st.emptyPixels);
        EXPECT_EQ(bareStats.polygonsDrawn, st.polygonsDrawn);
    }
    EXPECT_LE(differing[0], differing[1]);
}

// The two disocclusion searches (fill.h) fill every hole pixel alike: whole second eyes and hole
// classes identical, on office scenes for every rig.
TEST(Fill, BoxHierarchySearchGivesTheBspSearchsFrame) {
    for (int rooms : {2, 6}) {
        scene::Scene s = *scene::generateOffice(rooms);
        auto r = std::move(StereoRenderer::create({2})).value();
        // Prepared for the BSP search, it serves the box search too.
        ASSERT_TRUE(r->prepareReprojection(s, FillSearch::kBspOrder).isOk());
        for (const StereoRigDesc& desc : allRigs()) {
            StereoRig rig =
                *StereoRig::create(*scene::cameraAt(s, s.viewpoints.front(), 320, 240), desc);
            StereoOptions options;
            options.method = Method::kReproject;
            StereoFrame frames[2];
            StereoFrameStats stats[2];
            for (int i = 0; i < 2; ++i) {
                options.fillSearch = i == 0 ? FillSearch::kBspOrder : FillSearch::kBoxHierarchy;
                stats[i] = r->renderPair(s, rig, options, &frames[i]);
            }
            const std::string what = std::to_string(rooms) + " rooms, " + rigName(desc);
            EXPECT_GT(stats[0].disocclusionHoles, 0u) << what;
            for (Eye e : {Eye::kLeft, Eye::kRight}) {
                EXPECT_TRUE(frames[0].eye(e).color == frames[1].eye(e).color) << what;
                EXPECT_TRUE(frames[0].eye(e).depth == frames[1].eye(e).depth) << what;
                EXPECT_TRUE(frames[0].eye(e).id == frames[1].eye(e).id) << what;
            }
            EXPECT_TRUE(frames[0].holeClass == frames[1].holeClass) << what;
        }
    }
}

// Holes run in parallel with per-thread scratch; the result equals one thread's, on every ISA
// path of the first eye's renderer.
TEST(Fill, ThreadsAndIsaPathsGiveTheSameFrame) {
    scene::Scene s = *scene::generateOffice(3);
    StereoRig rig = *StereoRig::create(*scene::cameraAt(s, s.viewpoints.front(), 256, 160), {});
    StereoOptions options;
    options.method = Method::kReproject;
    ActiveIsaGuard restore;
    StereoFrame reference;
    auto one = std::move(StereoRenderer::create({1})).value();
    ASSERT_TRUE(setActiveIsa(Isa::kScalar).isOk());
    ASSERT_TRUE(one->prepareReprojection(s).isOk());
    one->renderPair(s, rig, options, &reference);
    for (Isa isa : runnableIsas()) {
        ASSERT_TRUE(setActiveIsa(isa).isOk());
        auto two = std::move(StereoRenderer::create({2})).value();
        ASSERT_TRUE(two->prepareReprojection(s).isOk());
        StereoFrame frame;
        two->renderPair(s, rig, options, &frame);
        for (Eye e : {Eye::kLeft, Eye::kRight}) {
            EXPECT_TRUE(frame.eye(e).color == reference.eye(e).color) << isaName(isa);
            EXPECT_TRUE(frame.eye(e).id == reference.eye(e).id) << isaName(isa);
        }
        EXPECT_TRUE(frame.holeClass == reference.holeClass) << isaName(isa);
    }
}

// A pair shown as colour only (the timed frames) writes the second eye's depth and IDs only
// where the hole search reads them; its colours and hole classes equal those of the pair with
// both planes, on every rig.
TEST(Fill, ColorOnlyPairEqualsThePairWithDepthAndIds) {
    scene::Scene s = *scene::generateOffice(3);
    Camera center = *scene::cameraAt(s, s.viewpoints.front(), 320, 200);
    auto r = std::move(StereoRenderer::create({2})).value();
    ASSERT_TRUE(r->prepareReprojection(s).isOk());
    for (StereoRigDesc desc : allRigs()) {
        StereoRig rig = *StereoRig::create(center, desc);
        StereoOptions options;
        options.method = Method::kReproject;
        StereoFrame planes, colorOnly;
        const StereoFrameStats withPlanes = r->renderPair(s, rig, options, &planes);
        options.writeDepthAndIds = false;
        StereoFrameStats stats = r->renderPair(s, rig, options, &colorOnly);
        EXPECT_GT(stats.holePixels, 0) << rigName(desc);
        EXPECT_TRUE(colorOnly.eye(rig.secondEye()).depth.empty()) << rigName(desc);
        for (Eye e : {Eye::kLeft, Eye::kRight})
            EXPECT_TRUE(colorOnly.eye(e).color == planes.eye(e).color) << rigName(desc);
        // The hole classes are left out with the planes; the counts are the same.
        EXPECT_TRUE(colorOnly.holeClass.empty()) << rigName(desc);
        EXPECT_FALSE(planes.holeClass.empty()) << rigName(desc);
        EXPECT_EQ(stats.holePixels, withPlanes.holePixels) << rigName(desc);
        EXPECT_EQ(stats.expansionPixels, withPlanes.expansionPixels) << rigName(desc);
        EXPECT_EQ(stats.disocclusionPixels, withPlanes.disocclusionPixels) << rigName(desc);
        EXPECT_EQ(stats.expansionHoles, withPlanes.expansionHoles) << rigName(desc);
        EXPECT_EQ(stats.disocclusionHoles, withPlanes.disocclusionHoles) << rigName(desc);
        EXPECT_EQ(stats.fillPolygonsTested, withPlanes.fillPolygonsTested) << rigName(desc);
        EXPECT_EQ(stats.fillPolygonsDrawn, withPlanes.fillPolygonsDrawn) << rigName(desc);
    }
}

TEST(Fill, MethodNamesAndPreparation) {
    EXPECT_EQ(*parseMethod("reproject"), Method::kReproject);
    EXPECT_STREQ(methodName(Method::kReproject), "reproject");
    Status bad = parseMethod("warp").status();
    EXPECT_NE(bad.message().find("full, pbuffer, reproject"), std::string::npos);
    scene::Scene s = *scene::generateOffice(1);
    auto r = std::move(StereoRenderer::create({1})).value();
    ASSERT_TRUE(r->prepareReprojection(s).isOk());
    EXPECT_GT(r->lastPrepareMs(), 0.0);
    // Prepared for the box search, a pair with the BSP search first needs the tree built.
    StereoRig rig = *StereoRig::create(*scene::cameraAt(s, s.viewpoints.front(), 160, 120), {});
    StereoOptions options;
    options.method = Method::kReproject;
    options.fillSearch = FillSearch::kBspOrder;
    ASSERT_TRUE(r->prepareReprojection(s, FillSearch::kBspOrder).isOk());
    StereoFrame frame;
    EXPECT_GT(r->renderPair(s, rig, options, &frame).holePixels, 0);
}

// The box search needs no BSP tree, so the default build leaves it out, and a scene whose tree
// cannot be built (here: any split exceeds the fragment bound) still gets the box search.
TEST(Fill, TheBoxSearchNeedsNoBspTree) {
    const scene::Scene s = *scene::generateOffice(2);
    const FillScene boxes = *buildFillScene(s);
    EXPECT_FALSE(boxes.bspBuilt);
    EXPECT_TRUE(boxes.bsp.empty());
    EXPECT_TRUE(boxes.serves(FillSearch::kBoxHierarchy));
    EXPECT_FALSE(boxes.serves(FillSearch::kBspOrder));
    EXPECT_FALSE(boxes.wideBoxes.empty());
    const FillScene both = *buildFillScene(s, FillSearch::kBspOrder);
    EXPECT_TRUE(both.bspBuilt && both.serves(FillSearch::kBoxHierarchy));
    EXPECT_EQ(both.fragmentsOfTriangle.size(), s.triangleCount());
    EXPECT_GT(both.bsp.fragmentCount(), s.triangleCount());  // office walls are split

    scene::BspConfig noSplits;
    noSplits.maxFragmentsPerTriangle = 1.0f;
    Status failed = buildFillScene(s, FillSearch::kBspOrder, noSplits).status();
    EXPECT_EQ(failed.code(), ErrorCode::kOutOfRange) << failed.message();
    auto withoutTree = buildFillScene(s, FillSearch::kBoxHierarchy, noSplits);
    ASSERT_TRUE(withoutTree.isOk()) << withoutTree.status().message();

    // The frames of both builds, with the box search: identical.
    StereoRig rig = *StereoRig::create(*scene::cameraAt(s, s.viewpoints.front(), 240, 160), {});
    auto r = std::move(raster::Renderer::create({1})).value();
    raster::FrameBuffers first;
    first.resize(240, 160);
    r->render(s, rig.first(), {}, first.targets());
    MovedSecondEye a(s, rig, first), b(s, rig, first);
    FillScratch scratch;
    const FillStats stats =
        fillHoles(s, boxes, rig.second(), {}, a.holes, a.targets(), a.classes.view(), &scratch);
    fillHoles(s, *withoutTree, rig.second(), {}, b.holes, b.targets(), b.classes.view(), &scratch);
    EXPECT_GT(stats.disocclusionPixels, 0);
    EXPECT_TRUE(a.eye.color == b.eye.color);
    EXPECT_TRUE(a.eye.id == b.eye.id);
    EXPECT_TRUE(a.classes == b.classes);
}

}  // namespace
}  // namespace plx::stereo
