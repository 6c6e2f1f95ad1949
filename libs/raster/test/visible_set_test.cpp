// VisibleSetCollector: the P-buffer's visible set (Heo, Jung, Wohn Fig. 6, last loop), its row
// scan on every ISA path against the distinct IDs of the target.

#include <algorithm>
#include <array>
#include <random>
#include <set>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <plx/raster/visible_set.h>
#include <plx/scene/generators.h>

#include "isa_paths.h"

namespace plx::raster {
namespace {

std::set<uint32_t> distinctTriangles(const Image<uint32_t>& ids) {
    std::set<uint32_t> out;
    for (size_t i = 0; i < ids.pixelCount(); ++i)
        if (ids.data()[i]) out.insert(ids.data()[i] - 1);
    return out;
}

class VisibleSetPath : public test::IsaPathTest {};
PLX_INSTANTIATE_ISA_PATHS(VisibleSetPath);

// Collecting during the render (each thread scanning the tiles it drew) finds exactly the
// distinct IDs a pass over the finished P-buffer finds, with many small tiles on two threads,
// and a second frame from elsewhere forgets the first.
TEST_P(VisibleSetPath, CollectingPerTileEqualsAPassOverTheIds) {
    scene::Scene s = *scene::generateOffice(3);
    auto renderer = std::move(Renderer::create({2, 16})).value();
    FrameBuffers fb;
    VisibleSetCollector perTile;
    RenderTargets targets;
    for (size_t view = 0; view < s.viewpoints.size(); ++view) {
        Camera cam = *scene::cameraAt(s, s.viewpoints[view], 203, 117);
        fb.resize(cam.width(), cam.height());
        perTile.begin(s.triangleCount(), renderer->threadCount());
        targets = fb.targets();
        targets.visibility.tileIds = &perTile;
        renderer->render(s, cam, {}, targets);
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
TEST_P(VisibleSetPath, FindsEveryIdAmongRepeatingNeighbours) {
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

// Rows wider than the collector's scratch holds several of are scanned one call per row, each
// continuing from the row above: every ID must still be found once, in the whole image and in
// tiles of it.
TEST_P(VisibleSetPath, WideRowsAreScannedAcrossKernelCalls) {
    std::mt19937 rng(11);
    Image<uint32_t> image(5003, 5);
    for (size_t i = 0; i < image.pixelCount(); ++i) image.data()[i] = uint32_t(rng() % 9000);
    std::set<uint32_t> expected = distinctTriangles(image);
    VisibleSetCollector whole, tiles;
    whole.begin(9000);
    whole.add(image);
    EXPECT_EQ(whole.sorted(), std::vector<uint32_t>(expected.begin(), expected.end()));
    tiles.begin(9000);
    tiles.visitTile(image.view(), 3, 0, 5002, 4, 0);
    tiles.visitTile(image.view(), 0, 0, 2, 4, 0);
    EXPECT_EQ(tiles.sorted(), whole.sorted());
}

TEST(VisibleSet, ForgetsEarlierFrames) {
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
TEST(VisibleSet, SortsSetsOfEverySizeAscending) {
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

}  // namespace
}  // namespace plx::raster
