// Cells, PVS + ACH (Marvie & Bouatouch section 5) and the scene database's files.

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include <plx/core/file.h>
#include <plx/scene/generators.h>
#include <plx/scene/import.h>
#include <plx/stream/database.h>

namespace plx::stream {
namespace {

namespace fs = std::filesystem;

// A quad p, p+u, p+u+v, p+v as two triangles.
void addQuad(scene::Mesh* m, Vec3 p, Vec3 u, Vec3 v) {
    uint32_t b = uint32_t(m->positions.size());
    for (Vec3 q : {p, p + u, p + u + v, p + v}) m->positions.push_back(q);
    for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) m->indices.push_back(b + i);
}

// Walls of the cube [x0, x0+2] x [0, 2] x [0, 2], the low and high x walls when asked. Each wall
// reaches `overlap` past the cube's edges, so that no pixel centre on an edge falls through a
// crack between two walls (the quads' windings are not consistent).
void addCubeWalls(scene::Mesh* m, float x0, bool lowX, bool highX, float overlap) {
    const float e = overlap;
    const Vec3 ex(2 + 2 * e, 0, 0), ey(0, 2 + 2 * e, 0), ez(0, 0, 2 + 2 * e);
    if (lowX) addQuad(m, Vec3(x0, -e, -e), ey, ez);
    if (highX) addQuad(m, Vec3(x0 + 2, -e, -e), ey, ez);
    addQuad(m, Vec3(x0 - e, 0, -e), ex, ez);  // floor
    addQuad(m, Vec3(x0 - e, 2, -e), ex, ez);  // ceiling
    addQuad(m, Vec3(x0 - e, -e, 0), ex, ey);  // z = 0
    addQuad(m, Vec3(x0 - e, -e, 2), ex, ey);  // z = 2
}

// Two 2 m cube rooms side by side along x, A = [0,2] and B = [2,4], open between them (A's +x
// face looks into B through the whole side). Their cell boxes are taller and deeper than the
// cubes so that the first Halton point (0.5, 1/3, 0.2) of each box, with no margin, is the
// cube's centre: from there each 90-degree face sees exactly one cube side.
scene::Scene twoOpenRooms() {
    scene::Scene s;
    scene::Mesh m;
    addCubeWalls(&m, 0.0f, true, false, 0.0f);
    addCubeWalls(&m, 2.0f, false, true, 0.0f);
    s.meshes.push_back(m);
    EXPECT_TRUE(s.finalize().isOk());
    s.rooms = {{Vec3(0, 0, 0), Vec3(2, 3, 5)}, {Vec3(2, 0, 0), Vec3(4, 3, 5)}};
    return s;
}

// Two closed cube rooms 2 cm apart; the cells are the cubes.
scene::Scene twoClosedRooms() {
    scene::Scene s;
    scene::Mesh m;
    addCubeWalls(&m, 0.0f, true, true, 0.005f);
    addCubeWalls(&m, 2.02f, true, true, 0.005f);
    s.meshes.push_back(m);
    EXPECT_TRUE(s.finalize().isOk());
    s.rooms = {{Vec3(0, 0, 0), Vec3(2, 2, 2)}, {Vec3(2.02f, 0, 0), Vec3(4.02f, 2, 2)}};
    return s;
}

VisibilityConfig centreSampling(int faceSize) {
    VisibilityConfig c;
    c.samples = 1;
    c.faceSize = faceSize;
    c.margin = 0.0f;
    return c;
}

std::vector<CellVisibility> visibilityOf(const scene::Scene& s, const Cells& cells,
                                         const VisibilityConfig& config) {
    auto v = computeVisibility(s, cells, config, 0, uint32_t(cells.boxes.size() - 1));
    EXPECT_TRUE(v.isOk()) << v.status().toString();
    return v.isOk() ? *v : std::vector<CellVisibility>{};
}

TEST(StreamCells, RoomsAreTheGeneratorsRooms) {
    auto museum = scene::generateMuseum(6).value();
    auto cells = makeCells(museum).value();
    ASSERT_TRUE(cells.fromRooms);
    ASSERT_EQ(cells.boxes.size(), 6u);
    EXPECT_EQ(cells.boxes[4].lo, Vec3(10, 0, 10));  // 3 columns: room 4 is column 1, row 1
    auto office = scene::generateOffice(5).value();
    EXPECT_EQ(makeCells(office).value().boxes.size(), 5u);
}

TEST(StreamCells, EveryTriangleInTheCellOfItsCentroid) {
    auto office = scene::generateOffice(4).value();
    for (bool kd : {false, true}) {
        CellConfig config;
        config.maxTrianglesPerCell = 500;
        auto cells = (kd ? kdCells(office, config) : makeCells(office, config)).value();
        ASSERT_EQ(cells.cellOfTriangle.size(), office.triangleCount());
        for (uint32_t t = 0; t < office.triangleCount(); ++t)
            ASSERT_EQ(cells.cellOfTriangle[t],
                      cellOfPoint(cells.boxes, triangleCentroid(office, t)))
                << "triangle " << t << (kd ? " (kd)" : " (rooms)");
    }
}

TEST(StreamCells, KdLeavesTileTheBoundsAndHoldAtMostTheLimit) {
    auto office = scene::generateOffice(4).value();
    CellConfig config;
    config.maxTrianglesPerCell = 700;
    config.minSideFraction = 0.0f;
    auto cells = kdCells(office, config).value();
    EXPECT_GT(cells.boxes.size(), office.triangleCount() / 700);
    std::vector<size_t> count(cells.boxes.size(), 0);
    for (uint32_t c : cells.cellOfTriangle) ++count[c];
    double volume = 0.0;
    for (size_t c = 0; c < cells.boxes.size(); ++c) {
        Vec3 e = cells.boxes[c].extent();
        volume += double(e.x) * e.y * e.z;
        EXPECT_LE(count[c], 700u) << "cell " << c;
        EXPECT_GT(count[c], 0u) << "cell " << c;  // median splits leave no side empty
    }
    Vec3 e = office.bounds().extent();
    EXPECT_NEAR(volume, double(e.x) * e.y * e.z, 1e-3 * double(e.x) * e.y * e.z);
    // The cell limit stops the splitting.
    config.maxKdCells = 3;
    EXPECT_EQ(kdCells(office, config).value().boxes.size(), 3u);
    config.maxTrianglesPerCell = 0;
    EXPECT_FALSE(kdCells(office, config).isOk());
}

TEST(StreamCells, AdjacencyOfAGrid) {
    auto museum = scene::generateMuseum(4).value();  // 2 x 2
    auto adjacent = adjacentCells(makeCells(museum).value().boxes);
    EXPECT_EQ(adjacent[0], (std::vector<uint32_t>{1, 2, 3}));  // corners touch too
    EXPECT_EQ(adjacent[3], (std::vector<uint32_t>{0, 1, 2}));
}

// The sweep against the definition: every pair tested, on boxes that touch, overlap, nest and
// share their low x.
TEST(StreamCells, AdjacencyEqualsEveryPairTested) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> corner(0.0f, 20.0f), side(0.0f, 3.0f);
    std::vector<Aabb> boxes;
    for (int i = 0; i < 400; ++i) {
        Vec3 lo(std::floor(corner(rng)), corner(rng), corner(rng));
        boxes.push_back({lo, lo + Vec3(std::floor(side(rng)), side(rng), side(rng))});
    }
    const float tolerance = 0.25f;
    std::vector<std::vector<uint32_t>> expected(boxes.size());
    for (uint32_t i = 0; i < boxes.size(); ++i)
        for (uint32_t j = 0; j < boxes.size(); ++j) {
            bool touch = i != j;
            for (int k = 0; k < 3; ++k)
                touch = touch && boxes[i].lo[k] <= boxes[j].hi[k] + tolerance &&
                        boxes[j].lo[k] <= boxes[i].hi[k] + tolerance;
            if (touch) expected[i].push_back(j);
        }
    EXPECT_EQ(adjacentCells(boxes, tolerance), expected);
}

TEST(StreamVisibility, SamplePointsSpreadInsideTheMarginAndNest) {
    Aabb box{Vec3(0, 0, 0), Vec3(10, 4, 10)};
    auto p8 = samplePoints(box, 8, 0.05f), p32 = samplePoints(box, 32, 0.05f);
    for (const Vec3& p : p32) {
        EXPECT_TRUE(glm::all(glm::greaterThanEqual(p, Vec3(0.5f, 0.2f, 0.5f)))) << p.x;
        EXPECT_TRUE(glm::all(glm::lessThanEqual(p, Vec3(9.5f, 3.8f, 9.5f)))) << p.x;
    }
    for (int i = 0; i < 8; ++i) EXPECT_EQ(p8[size_t(i)], p32[size_t(i)]);
    // Spread: the eight points fall in eight different octants of the box.
    std::set<int> octants;
    for (const Vec3& p : p8) octants.insert((p.x > 5) + 2 * (p.y > 2) + 4 * (p.z > 5));
    EXPECT_GE(octants.size(), 6u);
}

// Hand count: from the centre of A, four faces see A's floor, ceiling and side walls whole,
// the -x face A's end wall, and the +x face looks through the missing wall into B: N^2 pixels of
// B, 5 N^2 of A. ACH_A = 5/6, ACH_B = 1/6 (Marvie eq. 3); symmetric from B.
TEST(StreamVisibility, AchMatchesHandCountsOnTwoRooms) {
    auto s = twoOpenRooms();
    auto cells = makeCells(s).value();
    const uint64_t n2 = 48 * 48;
    auto vis = visibilityOf(s, cells, centreSampling(48));
    ASSERT_EQ(vis.size(), 2u);
    using Seen = std::vector<std::pair<uint32_t, uint64_t>>;
    EXPECT_EQ(vis[0].seen, (Seen{{0, 5 * n2}, {1, n2}}));
    EXPECT_EQ(vis[1].seen, (Seen{{0, n2}, {1, 5 * n2}}));
    auto pvs = pvsWithAch(vis[0]);
    ASSERT_EQ(pvs.size(), 2u);
    EXPECT_DOUBLE_EQ(pvs[0].ach, 5.0 / 6.0);
    EXPECT_DOUBLE_EQ(pvs[1].ach, 1.0 / 6.0);
    EXPECT_DOUBLE_EQ(pvs[0].ach + pvs[1].ach, 1.0);
}

// Texture coverage hints, by the same hand count: room B's walls (a second mesh) take their
// base colour from texture 0, A's are untextured. From A's centre the texture covers the N^2
// pixels seen through the opening; from B's, its 5 N^2. Untextured pixels are not listed.
TEST(StreamVisibility, TextureCountsMatchHandCountsOnTwoRooms) {
    scene::Scene s;
    scene::Mesh a, b;
    addCubeWalls(&a, 0.0f, true, false, 0.0f);
    addCubeWalls(&b, 2.0f, false, true, 0.0f);
    b.materialIndex = 1;
    s.meshes = {a, b};
    scene::Texture texture;
    texture.mips.push_back(Image<Rgba8>(2, 2));
    scene::buildMipChain(&texture);
    s.textures.push_back(texture);
    s.materials.resize(2);
    s.materials[1].baseColorTexture = 0;
    ASSERT_TRUE(s.finalize().isOk());
    s.rooms = {{Vec3(0, 0, 0), Vec3(2, 3, 5)}, {Vec3(2, 0, 0), Vec3(4, 3, 5)}};
    auto cells = makeCells(s).value();
    const uint64_t n2 = 40 * 40;
    auto vis = visibilityOf(s, cells, centreSampling(40));
    ASSERT_EQ(vis.size(), 2u);
    using Seen = std::vector<std::pair<uint32_t, uint64_t>>;
    EXPECT_EQ(vis[0].textures, (Seen{{0, n2}}));
    EXPECT_EQ(vis[1].textures, (Seen{{0, 5 * n2}}));
}

TEST(StreamVisibility, PvsOfAClosedRoomHoldsOnlyItself) {
    auto s = twoClosedRooms();
    auto cells = makeCells(s).value();
    VisibilityConfig config;  // eight samples spread over each box
    config.faceSize = 32;
    for (const CellVisibility& v : visibilityOf(s, cells, config)) {
        auto pvs = pvsWithAch(v);
        ASSERT_EQ(pvs.size(), 1u) << "cell " << v.cell << " sees " << pvs[0].cell << ": "
                                  << pvs[0].pixels << ", " << pvs[1].cell << ": " << pvs[1].pixels;
        EXPECT_EQ(pvs[0].cell, v.cell);
        EXPECT_EQ(pvs[0].ach, 1.0);
    }
}

// Far from the origin a unit step from the eye is lost to float rounding (at 1e8 the spacing is
// 8): the rendering box's cameras must still look somewhere.
TEST(StreamVisibility, RoomsFarFromTheOriginStillSeeOnlyThemselves) {
    scene::Scene s = twoClosedRooms();
    constexpr float kScale = 1e8f;
    for (scene::Mesh& m : s.meshes)
        for (Vec3& p : m.positions) p *= kScale;
    for (Aabb& room : s.rooms) room = {room.lo * kScale, room.hi * kScale};
    ASSERT_TRUE(s.finalize().isOk());
    auto cells = makeCells(s).value();
    VisibilityConfig config;
    config.faceSize = 32;
    for (const CellVisibility& v : visibilityOf(s, cells, config)) {
        auto pvs = pvsWithAch(v);
        ASSERT_EQ(pvs.size(), 1u) << "cell " << v.cell;
        EXPECT_EQ(pvs[0].cell, v.cell);
    }
}

TEST(StreamVisibility, AchsSumToOneAndThreadCountDoesNotMatter) {
    auto museum = scene::generateMuseum(9).value();
    auto cells = makeCells(museum).value();
    VisibilityConfig config;
    config.faceSize = 32;
    config.threads = 1;
    auto one = visibilityOf(museum, cells, config);
    config.threads = 2;
    auto two = visibilityOf(museum, cells, config);
    ASSERT_EQ(one.size(), 9u);
    const auto adjacent = adjacentCells(cells.boxes);
    for (size_t c = 0; c < one.size(); ++c) {
        EXPECT_EQ(one[c].seen, two[c].seen) << "cell " << c;
        double sum = 0.0;
        bool self = false;
        for (const PvsEntry& e : pvsWithAch(one[c])) {
            sum += e.ach;
            self = self || e.cell == c;
        }
        EXPECT_NEAR(sum, 1.0, 1e-12);
        EXPECT_TRUE(self);
        // Through the doorways each room sees its grid neighbours.
        std::set<uint32_t> seen;
        for (auto [cell, px] : one[c].seen) seen.insert(cell);
        for (uint32_t a : adjacent[c]) {
            bool sharesWall = cells.boxes[a].lo.x == cells.boxes[c].lo.x ||
                              cells.boxes[a].lo.z == cells.boxes[c].lo.z;
            if (sharesWall) {
                EXPECT_TRUE(seen.count(a)) << c << " does not see " << a;
            }
        }
    }
}

TEST(StreamVisibility, BadRequestsAreErrors) {
    auto s = twoOpenRooms();
    auto cells = makeCells(s).value();
    VisibilityConfig c;
    EXPECT_FALSE(computeVisibility(s, cells, c, 1, 0).isOk());
    EXPECT_FALSE(computeVisibility(s, cells, c, 0, 2).isOk());
    c.samples = 0;
    EXPECT_FALSE(computeVisibility(s, cells, c, 0, 1).isOk());
    c.samples = 8;
    c.faceSize = 4;
    EXPECT_FALSE(computeVisibility(s, cells, c, 0, 1).isOk());
}

std::span<const uint8_t> bytesOf(const std::string& s) {
    return {reinterpret_cast<const uint8_t*>(s.data()), s.size()};
}

std::string readAll(const fs::path& p) {
    return readFileChecked(p.string()).value();
}

std::map<std::string, std::string> filesBelow(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.is_regular_file()) files[fs::relative(e.path(), dir).string()] = readAll(e.path());
    return files;
}

fs::path freshDir(const std::string& name) {
    fs::path dir = fs::path(PLX_TEST_OUTPUT_DIR) / "stream" / name;
    fs::remove_all(dir);
    return dir;
}

struct Built {
    scene::Scene scene;
    Cells cells;
    VisibilityConfig config;
    std::vector<CellVisibility> visibility;
};

Built buildMuseum4() {
    Built b{scene::generateMuseum(4).value(), {}, {}, {}};
    b.cells = makeCells(b.scene).value();
    b.config.samples = 2;
    b.config.faceSize = 32;
    b.visibility = visibilityOf(b.scene, b.cells, b.config);
    return b;
}

TEST(StreamDatabase, RangesMergedEqualTheWholeBuild) {
    Built b = buildMuseum4();
    fs::path whole = freshDir("whole"), merged = freshDir("merged");
    auto stats =
        writeDatabase(b.scene, b.cells, b.visibility, b.config, "museum:4", whole.string());
    ASSERT_TRUE(stats.isOk()) << stats.status().toString();
    EXPECT_EQ(stats->cells, 4u);
    EXPECT_EQ(stats->textures, b.scene.textures.size());
    // Two parts, through their JSON files, joined.
    const std::string hash = sceneHash(b.scene, b.cells);
    std::vector<PartFile> parts;
    for (auto [first, last] : {std::pair<uint32_t, uint32_t>{2, 3}, {0, 1}}) {
        PartFile p{hash, 4, first, last, b.config.samples, b.config.faceSize, {}};
        p.visibility = computeVisibility(b.scene, b.cells, b.config, first, last).value();
        auto back = parsePart(bytesOf(serializePart(p)));
        ASSERT_TRUE(back.isOk()) << back.status().toString();
        parts.push_back(*back);
    }
    auto all = mergeParts(parts, hash, 4);
    ASSERT_TRUE(all.isOk()) << all.status().toString();
    ASSERT_TRUE(writeDatabase(b.scene, b.cells, *all, b.config, "museum:4", merged.string()));
    auto a = filesBelow(whole), m = filesBelow(merged);
    EXPECT_EQ(a.size(), 1 + 2 * 4 + b.scene.textures.size());
    EXPECT_TRUE(a == m);
    // A part naming a texture the scene does not have is refused.
    auto hostile = *all;
    hostile[1].textures.emplace_back(uint32_t(b.scene.textures.size()), 1);
    auto refused =
        writeDatabase(b.scene, b.cells, hostile, b.config, "museum:4", freshDir("bad").string());
    ASSERT_FALSE(refused.isOk());
    EXPECT_NE(refused.status().message().find("names texture"), std::string::npos);
    // Merge refuses gaps, overlaps and other scenes.
    EXPECT_FALSE(mergeParts({parts[0]}, hash, 4).isOk());
    EXPECT_FALSE(mergeParts({parts[0], parts[1], parts[1]}, hash, 4).isOk());
    // Counts and cells out of range are refused before anything is allocated for them.
    EXPECT_FALSE(mergeParts({}, hash, UINT32_MAX).isOk());
    EXPECT_FALSE(mergeParts({}, hash, 0).isOk());
    PartFile stray = parts[0];
    stray.visibility[0].cell = 4;
    auto strayMerge = mergeParts({stray, parts[1]}, hash, 4);
    ASSERT_FALSE(strayMerge.isOk());
    EXPECT_EQ(strayMerge.status().message(), "part 1 names cell 4 of 4");
    EXPECT_FALSE(mergeParts(parts, "0123456789abcdef", 4).isOk());
}

TEST(StreamDatabase, RoundTripThroughTheReaders) {
    Built b = buildMuseum4();
    fs::path dir = freshDir("roundtrip");
    ASSERT_TRUE(writeDatabase(b.scene, b.cells, b.visibility, b.config, "museum:4", dir.string()));
    std::string rootText = readAll(dir / "root.json");
    auto root = parseRoot(bytesOf(rootText));
    ASSERT_TRUE(root.isOk()) << root.status().toString();
    EXPECT_EQ(root->cells, 4u);
    EXPECT_EQ(root->viewpoints[0].name, "default");
    EXPECT_EQ(root->viewpoints[0].cellUrl, "cells/c00000.json");
    EXPECT_EQ(serializeRoot(*root), rootText);
    for (uint32_t c = 0; c < 4; ++c) {
        std::string text = readAll(dir / cellUrl(c));
        auto cell = parseCell(bytesOf(text));
        ASSERT_TRUE(cell.isOk()) << cell.status().toString();
        EXPECT_EQ(serializeCell(*cell), text);
        EXPECT_EQ(cell->index, c);
        EXPECT_EQ(cell->samples, 2);
        EXPECT_EQ(cell->geometry.bytes, fs::file_size(dir / cell->geometry.url));
        for (const UrlBytes& t : cell->textures)
            EXPECT_EQ(t.bytes, fs::file_size(dir / t.url)) << t.url;
        EXPECT_EQ(cell->adjacent.size(), 3u);
        // Texture coverage hints: textures of the database, ascending, within the sampling.
        ASSERT_FALSE(cell->textureCoverage.empty());
        uint64_t covered = 0;
        for (size_t k = 0; k < cell->textureCoverage.size(); ++k) {
            const auto [texture, pixels] = cell->textureCoverage[k];
            EXPECT_TRUE(fs::exists(dir / textureUrl(texture))) << texture;
            if (k > 0) {
                EXPECT_LT(cell->textureCoverage[k - 1].first, texture);
            }
            covered += pixels;
        }
        EXPECT_LE(covered, cell->totalPixels);
        // The geometry reads back with a real glTF importer, every triangle of the cell.
        auto glb = scene::importFile((dir / cell->geometry.url).string());
        ASSERT_TRUE(glb.isOk()) << glb.status().toString();
        EXPECT_EQ(glb->triangleCount(), cell->triangles);
    }
}

TEST(StreamDatabase, ReadersRefuseEveryTruncatedPrefixAndFlippedBytes) {
    Built b = buildMuseum4();
    fs::path dir = freshDir("prefixes");
    ASSERT_TRUE(writeDatabase(b.scene, b.cells, b.visibility, b.config, "museum:4", dir.string()));
    const std::string root = readAll(dir / "root.json"), cell = readAll(dir / cellUrl(1));
    PartFile p{"0123456789abcdef", 4, 0, 3, 2, 32, b.visibility};
    const std::string part = serializePart(p);
    for (size_t n = 0; n < root.size(); ++n)
        EXPECT_FALSE(parseRoot(bytesOf(root.substr(0, n))).isOk()) << n;
    for (size_t n = 0; n < cell.size(); ++n)
        EXPECT_FALSE(parseCell(bytesOf(cell.substr(0, n))).isOk()) << n;
    for (size_t n = 0; n < part.size(); ++n)
        EXPECT_FALSE(parsePart(bytesOf(part.substr(0, n))).isOk()) << n;
    // Flipped bytes: an error or a file that still meets every invariant, never a crash.
    for (size_t i = 0; i < cell.size(); ++i) {
        std::string bad = cell;
        bad[i] = char(bad[i] ^ 0x5a);
        auto r = parseCell(bytesOf(bad));
        if (r.isOk()) {
            EXPECT_TRUE(parseCell(bytesOf(serializeCell(*r))).isOk());
        }
    }
    // Texture coverage hints out of order, empty, or covering more than the sampling saw.
    const CellFile good = parseCell(bytesOf(cell)).value();
    ASSERT_GE(good.textureCoverage.size(), 2u);
    auto refusedWhen = [&](auto edit, const char* what) {
        CellFile bad = good;
        edit(bad.textureCoverage);
        auto r = parseCell(bytesOf(serializeCell(bad)));
        ASSERT_FALSE(r.isOk()) << what;
        EXPECT_NE(r.status().message().find("texture_coverage"), std::string::npos) << what;
    };
    refusedWhen([](auto& t) { std::swap(t[0], t[1]); }, "descending");
    refusedWhen([](auto& t) { t[0].second = 0; }, "zero pixels");
    refusedWhen([&](auto& t) { t[0].second = good.totalPixels; }, "over the total");
    refusedWhen([](auto& t) { t.back().first = uint32_t(kMaxTextures); }, "no such texture");
    // Errors are one line.
    auto e = parseCell(bytesOf(cell.substr(0, cell.size() / 2)));
    EXPECT_EQ(e.status().message().find('\n'), std::string::npos);
}

TEST(StreamDatabase, HostileContentIsRefused) {
    for (const char* url : {"", "/etc/passwd", "../x", "cells/../../x", "http://h/x", "a//b", "./a",
                            "a/./b", "a\\b", "a?b", "a%2e", "cells/c00000.json/.."})
        EXPECT_FALSE(checkUrl(url).isOk()) << url;
    EXPECT_TRUE(checkUrl("cells/c00000.json").isOk());
    EXPECT_FALSE(cellIndexOfUrl("cells/c00004.json", 4).isOk());
    EXPECT_FALSE(cellIndexOfUrl("cells/c0001.json", 4).isOk());
    EXPECT_EQ(cellIndexOfUrl("cells/c00003.json", 4).value(), 3u);
    std::string deep(100, '[');
    EXPECT_FALSE(parseRoot(bytesOf(deep)).isOk());
    const std::string root = R"({"bounds":{"max":[1,1,1],"min":[0,0,0]},"cells":1,)"
                             R"("format":"parallax-stream","scene":"x","textures":0,)"
                             R"("version":1,"viewpoints":[{"cell":"CELL","eye":[0,0,0],)"
                             R"("fov_y_degrees":60,"name":"a","target":[0,0,-1],"up":[0,1,0]}]})";
    auto with = [&](const std::string& cell) {
        std::string t = root;
        t.replace(t.find("CELL"), 4, cell);
        return parseRoot(bytesOf(t));
    };
    EXPECT_TRUE(with("cells/c00000.json").isOk()) << with("cells/c00000.json").status().toString();
    EXPECT_FALSE(with("../cells/c00000.json").isOk());
    EXPECT_FALSE(with("cells/c00001.json").isOk());
    std::string version2 = root;
    version2.replace(version2.find("\"version\":1"), 11, "\"version\":2");
    EXPECT_FALSE(parseRoot(bytesOf(version2)).isOk());
}

TEST(StreamDatabase, WritesOnlyBelowItsFolderAndNotThroughLinks) {
    fs::path dir = freshDir("links");
    fs::create_directories(dir);
    const std::string data = "x";
    EXPECT_FALSE(writeBelow(dir.string(), "../escape", bytesOf(data)).isOk());
    EXPECT_FALSE(writeBelow(dir.string(), "/tmp/escape", bytesOf(data)).isOk());
    fs::path outside = freshDir("outside");
    fs::create_directories(outside);
    fs::create_directory_symlink(outside, dir / "cells");
    EXPECT_FALSE(writeBelow(dir.string(), "cells/c00000.json", bytesOf(data)).isOk());
    EXPECT_TRUE(fs::is_empty(outside));
    EXPECT_TRUE(writeBelow(dir.string(), "root.json", bytesOf(data)).isOk());
}

}  // namespace
}  // namespace plx::stream
