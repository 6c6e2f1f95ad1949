#include <algorithm>
#include <array>
#include <random>
#include <set>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <plx/scene/generators.h>
#include <plx/stereo/layout.h>
#include <plx/stereo/path.h>
#include <plx/stereo/stereo.h>

namespace plx::stereo {
namespace {

Camera officeCamera(const scene::Scene& s, int w = 160, int h = 120) {
    return *scene::cameraAt(s, s.viewpoints.front(), w, h);
}

std::unique_ptr<StereoRenderer> makeRenderer() {
    return std::move(StereoRenderer::create({2})).value();
}

std::set<uint32_t> distinctTriangles(const Image<uint32_t>& ids) {
    std::set<uint32_t> out;
    for (size_t i = 0; i < ids.pixelCount(); ++i)
        if (ids.data()[i]) out.insert(ids.data()[i] - 1);
    return out;
}

// The premise of Table 1: from the office's default viewpoint the visible polygons level off as
// rooms are added (the second eye's cost follows them), while the "vista" viewpoint, which sees
// the horizon, keeps gaining polygons from far rooms.
TEST(Stereo, OfficeDefaultViewpointVisibleSetLevelsOff) {
    auto visibleAt = [](int rooms, size_t viewpoint) {
        scene::Scene s = *scene::generateOffice(rooms);
        auto rig = *StereoRig::create(*scene::cameraAt(s, s.viewpoints[viewpoint], 320, 240), {});
        auto r = makeRenderer();
        StereoFrame frame;
        return r->renderPair(s, rig, {}, &frame).visibleTriangles;
    };
    size_t at8 = visibleAt(8, 0), at32 = visibleAt(32, 0);
    EXPECT_LE(double(at32), 1.05 * double(at8)) << at8 << " -> " << at32;
    size_t vista8 = visibleAt(8, 1), vista32 = visibleAt(32, 1);
    EXPECT_GT(double(vista32), 1.2 * double(vista8)) << vista8 << " -> " << vista32;
}

TEST(Stereo, VisibleSetIsTheDistinctIdsOfThePBuffer) {
    scene::Scene s = *scene::generateOffice(4);
    auto rig = StereoRig::create(officeCamera(s), {});
    ASSERT_TRUE(rig.isOk());
    auto r = makeRenderer();
    StereoFrame frame;
    StereoFrameStats st = r->renderPair(s, *rig, {}, &frame);
    std::set<uint32_t> expected = distinctTriangles(frame.eye(rig->desc().firstEye).id);
    std::vector<uint32_t> got(r->lastVisibleSet().begin(), r->lastVisibleSet().end());
    EXPECT_EQ(std::set<uint32_t>(got.begin(), got.end()), expected);
    EXPECT_TRUE(std::is_sorted(got.begin(), got.end()));
    EXPECT_EQ(st.visibleTriangles, expected.size());
    EXPECT_EQ(st.secondEyeTriangles, expected.size());
    EXPECT_LT(st.visibleTriangles, s.triangleCount() / 4);
}

// Collecting during the render (each thread scanning the tiles it drew) finds exactly the
// distinct IDs a pass over the finished P-buffer finds, with many small tiles on two threads,
// and a second frame from elsewhere forgets the first.
TEST(Stereo, CollectingPerTileEqualsAPassOverTheIds) {
    scene::Scene s = *scene::generateOffice(3);
    auto renderer = std::move(raster::Renderer::create({2, 16})).value();
    raster::FrameBuffers fb;
    VisibleSetCollector perTile;
    raster::RenderOptions options;
    options.tileIds = &perTile;
    for (size_t view = 0; view < s.viewpoints.size(); ++view) {
        Camera cam = *scene::cameraAt(s, s.viewpoints[view], 203, 117);
        fb.resize(cam.width(), cam.height());
        perTile.begin(s.triangleCount(), renderer->threadCount());
        renderer->render(s, cam, options, fb.targets());
        std::set<uint32_t> expected = distinctTriangles(fb.id);
        ASSERT_GT(expected.size(), 100u);
        EXPECT_EQ(perTile.size(), expected.size()) << "viewpoint " << view;
        const std::vector<uint32_t>& got = perTile.sorted();
        EXPECT_EQ(std::set<uint32_t>(got.begin(), got.end()), expected) << "viewpoint " << view;
        EXPECT_EQ(got.size(), expected.size()) << "duplicates, viewpoint " << view;
        VisibleSetCollector onePass;
        onePass.begin(s.triangleCount());
        onePass.add(fb.id);
        EXPECT_EQ(onePass.sorted(), got) << "viewpoint " << view;
    }
}

// Pixels are skipped when they repeat their left or upper neighbour's ID: images of overlapping
// rectangles (runs and columns of one ID, as polygons give) sprinkled with single pixels, some as
// wide as the eight-pixel groups and some not, must still give every ID, whole and per tile.
TEST(Stereo, CollectorFindsEveryIdAmongRepeatingNeighbours) {
    std::mt19937 rng(7);
    auto below = [&](int n) { return std::uniform_int_distribution<int>(0, n - 1)(rng); };
    for (int trial = 0; trial < 300; ++trial) {
        const int width = std::array{1, 8, 19, 40}[trial % 4];
        const int ids = std::array{2, 5, 40}[trial % 3];
        Image<uint32_t> image(width, 9);
        for (int id = 1; id <= ids; ++id) {
            int x = below(width), y = below(9);
            int w = 1 + below(width - x), h = 1 + below(9 - y);
            for (int v = y; v < y + h; ++v)
                for (int u = x; u < x + w; ++u) image.at(u, v) = uint32_t(id);
        }
        for (int k = 0; k < 3; ++k) image.at(below(width), below(9)) = uint32_t(ids + 1 + k);
        std::set<uint32_t> expected = distinctTriangles(image);
        const std::string what = fmt::format("trial {}: {} wide, {} IDs", trial, width, ids);
        VisibleSetCollector whole, tiles;
        whole.begin(64);
        whole.add(image);
        EXPECT_EQ(std::set<uint32_t>(whole.sorted().begin(), whole.sorted().end()), expected)
            << what;
        tiles.begin(64);
        for (int y0 = 0; y0 < 9; y0 += 4)
            tiles.visitTile(image.view(), 0, y0, width - 1, std::min(y0 + 3, 8), 0);
        EXPECT_EQ(tiles.sorted(), whole.sorted()) << what;
    }
}

TEST(Stereo, CollectorForgetsEarlierFrames) {
    VisibleSetCollector c;
    Image<uint32_t> a(4, 1), b(4, 1);
    a.at(0, 0) = 3;
    a.at(1, 0) = 5;
    b.at(2, 0) = 2;
    c.begin(10);
    c.add(a);
    EXPECT_EQ(c.sorted(), (std::vector<uint32_t>{2, 4}));
    c.begin(10);
    c.add(b);
    EXPECT_EQ(c.sorted(), (std::vector<uint32_t>{1}));
    EXPECT_FALSE(c.contains(2));
    EXPECT_TRUE(c.contains(1));
    // Flags set by tile visits on two slots, the frame never sorted: a new frame clears them too,
    // and so does a change of scene size.
    c.begin(10, 2);
    c.visitTile(a.view(), 0, 0, 1, 0, 0);
    c.visitTile(a.view(), 2, 0, 3, 0, 1);
    c.visitTile(b.view(), 0, 0, 3, 0, 1);
    EXPECT_TRUE(c.contains(4) && c.contains(1));
    c.begin(10, 2);
    for (uint32_t t = 0; t < 10; ++t) EXPECT_FALSE(c.contains(t)) << t;
    c.addTriangles(std::vector<uint32_t>{7});
    c.begin(200);
    EXPECT_FALSE(c.contains(7));
    EXPECT_TRUE(c.sorted().empty());
}

// sorted() switches from std::sort to a radix sort at 256 IDs, with as many digit passes as the
// triangle count needs: lists on both sides of the switch, scene sizes of one to three passes.
TEST(Stereo, CollectorSortsSetsOfEverySizeAscending) {
    std::mt19937 rng(7);
    for (size_t triangles : {size_t(300), size_t(5000), size_t(1) << 20, (size_t(1) << 22) + 1}) {
        VisibleSetCollector c;
        for (size_t n : {0, 1, 255, 256, 257, 1000, 4000}) {
            // Distinct IDs in random order, the first and last triangles among them.
            std::set<uint32_t> ids;
            for (uint32_t t : {uint32_t(0), uint32_t(triangles - 1)})
                if (ids.size() < n) ids.insert(t);
            while (ids.size() < std::min(n, triangles)) ids.insert(uint32_t(rng() % triangles));
            std::vector<uint32_t> all(ids.begin(), ids.end());
            std::shuffle(all.begin(), all.end(), rng);
            c.begin(triangles);
            c.addTriangles(all);
            EXPECT_EQ(c.sorted(), std::vector<uint32_t>(ids.begin(), ids.end()))
                << triangles << " triangles, " << n << " IDs";
        }
    }
}

TEST(Stereo, SubsetOfAllIdsReproducesTheFullRender) {
    scene::Scene s = *scene::generateOffice(2);
    Camera cam = officeCamera(s);
    auto r = makeRenderer();
    raster::FrameBuffers full, subset;
    full.resize(cam.width(), cam.height());
    subset.resize(cam.width(), cam.height());
    r->renderer().render(s, cam, {}, full.targets());
    std::set<uint32_t> ids = distinctTriangles(full.id);
    std::vector<uint32_t> visible(ids.begin(), ids.end());
    r->renderer().renderSubset(s, cam, visible, {}, subset.targets());
    EXPECT_TRUE(subset.id == full.id);
    EXPECT_TRUE(subset.depth == full.depth);
    EXPECT_TRUE(subset.color == full.color);
}

TEST(Stereo, ZeroSeparationGivesIdenticalImagesForBothMethods) {
    scene::Scene s = *scene::generateOffice(3);
    StereoRigDesc desc;
    desc.separation = 0.0f;
    auto rig = StereoRig::create(officeCamera(s), desc);
    ASSERT_TRUE(rig.isOk());
    auto r = makeRenderer();
    StereoFrame full, pbuf;
    StereoOptions options;
    options.method = Method::kFull;
    r->renderPair(s, *rig, options, &full);
    options.method = Method::kPBuffer;
    r->renderPair(s, *rig, options, &pbuf);
    for (Eye e : {Eye::kLeft, Eye::kRight}) {
        EXPECT_TRUE(full.eye(e).color == pbuf.eye(e).color);
        EXPECT_TRUE(full.eye(e).id == pbuf.eye(e).id);
    }
    SecondEyeQuality q = compareSecondEye(pbuf.eye(rig->secondEye()), full.eye(rig->secondEye()),
                                          r->lastVisibleSet());
    EXPECT_TRUE(std::isinf(q.psnrDb));
    EXPECT_EQ(q.missedPolygons, 0u);
}

// Colour alone (the experiment's timed frames): the same colour and visible set as with depth and
// IDs written, for every method; the eyes' depth and ID images are left empty, except the
// conservative method's first eye; a later frame with planes gets them back.
TEST(Stereo, ColourOnlyEyesMatchTheCompleteRender) {
    scene::Scene s = *scene::generateOffice(5);
    auto rig = StereoRig::create(officeCamera(s, 160, 120), {});
    ASSERT_TRUE(rig.isOk());
    auto r = makeRenderer();
    const Eye first = rig->desc().firstEye;
    for (int variant = 0; variant < 3; ++variant) {
        StereoOptions options;
        options.method = variant == 0 ? Method::kFull : Method::kPBuffer;
        options.conservative = variant == 2;
        StereoFrame complete, colour;
        // Twice: the conservative guard band is sized from the previous frame's nearest depth.
        r->renderPair(s, *rig, options, &complete);
        StereoFrameStats a = r->renderPair(s, *rig, options, &complete);
        std::vector<uint32_t> set(r->lastVisibleSet().begin(), r->lastVisibleSet().end());
        options.writeDepthAndIds = false;
        colour = complete;  // stale planes that must not survive
        StereoFrameStats b = r->renderPair(s, *rig, options, &colour);
        const std::string what = "variant " + std::to_string(variant);
        EXPECT_TRUE(std::equal(set.begin(), set.end(), r->lastVisibleSet().begin(),
                               r->lastVisibleSet().end()))
            << what;
        EXPECT_EQ(b.secondEyeTriangles, a.secondEyeTriangles) << what;
        for (Eye e : {Eye::kLeft, Eye::kRight}) {
            EXPECT_TRUE(colour.eye(e).color == complete.eye(e).color) << what;
            const bool kept = options.conservative && e == first;
            EXPECT_EQ(colour.eye(e).id.empty(), !kept) << what;
            EXPECT_EQ(colour.eye(e).depth.empty(), !kept) << what;
        }
        if (variant > 0) {
            EXPECT_EQ(b.visibleTriangles, a.visibleTriangles) << what;
        }
        options.writeDepthAndIds = true;
        r->renderPair(s, *rig, options, &colour);
        for (Eye e : {Eye::kLeft, Eye::kRight}) {
            EXPECT_TRUE(colour.eye(e).id == complete.eye(e).id) << what;
            EXPECT_TRUE(colour.eye(e).depth == complete.eye(e).depth) << what;
        }
    }
}

TEST(Stereo, SecondEyeIsCloseToFullAndConservativeRecoversMissedPolygons) {
    scene::Scene s = *scene::generateOffice(6);
    StereoRigDesc desc;
    desc.separation = 0.2f;  // wide, so that some polygons are newly visible to the second eye
    auto rig = StereoRig::create(officeCamera(s, 200, 150), desc);
    ASSERT_TRUE(rig.isOk());
    auto r = makeRenderer();
    StereoFrame full, pbuf, cons;
    StereoOptions options;
    options.method = Method::kFull;
    r->renderPair(s, *rig, options, &full);
    options.method = Method::kPBuffer;
    r->renderPair(s, *rig, options, &pbuf);
    std::vector<uint32_t> plainSet(r->lastVisibleSet().begin(), r->lastVisibleSet().end());
    options.conservative = true;
    StereoFrameStats cst = r->renderPair(s, *rig, options, &cons);
    Eye second = rig->secondEye();
    SecondEyeQuality plain = compareSecondEye(pbuf.eye(second), full.eye(second), plainSet);
    SecondEyeQuality conservative =
        compareSecondEye(cons.eye(second), full.eye(second), r->lastVisibleSet());
    EXPECT_GT(plain.missedPolygons, 0u) << "the test needs a separation that reveals polygons";
    EXPECT_LT(conservative.missedPolygons, plain.missedPolygons);
    EXPECT_LT(conservative.missedPixels, plain.missedPixels);
    EXPECT_GT(cst.conservativeExtra, 0u);
    EXPECT_GT(cst.guardBandPx, 0);
    EXPECT_GT(plain.psnrDb, 20.0);
    // The first eye's image is the same with and without the guard band (up to rounding of the
    // wider projection on a few edge pixels).
    ImageDiffStats d = compareImages(cons.eye(rig->desc().firstEye).color,
                                     pbuf.eye(rig->desc().firstEye).color, 0);
    EXPECT_LT(d.differingPixels, 200 * 150 / 100);
}

TEST(Stereo, LayoutsPlaceTheEyesAsDocumented) {
    Image<Rgba8> l(3, 2, Rgba8{200, 10, 20, 255}), r(3, 2, Rgba8{5, 100, 150, 255});
    Image<Rgba8> sbs = composeStereo(l, r, Layout::kSideBySide);
    EXPECT_EQ(sbs.width(), 6);
    EXPECT_EQ(sbs.at(0, 1), l.at(0, 1));
    EXPECT_EQ(sbs.at(3, 0), r.at(0, 0));
    Image<Rgba8> tb = composeStereo(l, r, Layout::kTopBottom);
    EXPECT_EQ(tb.height(), 4);
    EXPECT_EQ(tb.at(2, 3), r.at(2, 1));
    Image<Rgba8> ana = composeStereo(l, r, Layout::kAnaglyph);
    EXPECT_EQ(ana.at(1, 1), (Rgba8{200, 100, 150, 255}));
    Image<Rgba8> il = composeStereo(l, r, Layout::kInterleaved);
    EXPECT_EQ(il.at(0, 0), l.at(0, 0));
    EXPECT_EQ(il.at(0, 1), r.at(0, 1));
}

TEST(Stereo, BadNamesAndPathsGiveClearErrors) {
    EXPECT_FALSE(parseMethod("raytrace").isOk());
    EXPECT_FALSE(parseLayout("hologram").isOk());
    EXPECT_NE(parsePath("[").status().message().find("JSON"), std::string::npos);
    EXPECT_NE(parsePath("[]").status().message().find("no poses"), std::string::npos);
    EXPECT_NE(parsePath(R"([{"eye":[0,0,0]}])").status().message().find("target"),
              std::string::npos);
    EXPECT_NE(parsePath(R"([{"eye":[0,0,"x"],"target":[0,0,1]}])").status().message().find("eye"),
              std::string::npos);
    EXPECT_FALSE(parsePath(R"([{"eye":[0,0,0],"target":[0,0,1],"fov":500}])").isOk());
    auto ok = parsePath(R"({"poses":[{"eye":[0,1,0],"target":[0,1,-1],"fov":50}]})");
    ASSERT_TRUE(ok.isOk());
    EXPECT_EQ(ok->size(), 1u);
    EXPECT_EQ((*ok)[0].fovYDegrees, 50.0f);
}

TEST(Stereo, EveryPrefixOfAPathParsesOrFailsCleanly) {
    const std::string text =
        R"({"poses": [{"eye": [1, 1.6, 1], "target": [5, 1, 5], "up": [0, 1, 0], "fov": 55},)"
        R"( {"eye": [1.2, 1.6, 1], "target": [5, 1, 5]}]})";
    ASSERT_TRUE(parsePath(text).isOk());
    for (size_t cut = 0; cut < text.size(); ++cut) {
        auto r = parsePath(text.substr(0, cut));
        EXPECT_FALSE(r.isOk()) << "prefix " << cut;
        EXPECT_FALSE(r.status().message().empty());
    }
}

}  // namespace
}  // namespace plx::stereo
