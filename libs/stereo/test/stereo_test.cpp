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
