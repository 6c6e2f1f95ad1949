// The allocation policies of the comparison (budget.h): the equal split's shares, LRU's eviction
// order, ACH with unusable shares returned against the paper's rule, the split by texture
// coverage hints, every policy under the hard cap on random walks; and the tour through every
// cell.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>

#include <gtest/gtest.h>

#include <plx/scene/generators.h>
#include <plx/stream/budget.h>
#include <plx/stream/cells.h>
#include <plx/stream/client.h>
#include <plx/stream/database.h>
#include <plx/stream/link_simulator.h>
#include <plx/stream/tour.h>

namespace plx::stream {
namespace {

namespace fs = std::filesystem;

constexpr AllocationPolicy kPolicies[] = {AllocationPolicy::kAch, AllocationPolicy::kAchReturn,
                                          AllocationPolicy::kAchTexture, AllocationPolicy::kLru,
                                          AllocationPolicy::kEqualSplit};

// Levels of 1, 4, 16, 64 bytes: chains S = 1, 5, 21, 85.
PtmNode node(int resident = 0) {
    PtmNode n;
    n.levelBytes = {1, 4, 16, 64};
    n.groupBytes.assign(4, 10);
    n.resident = n.downloaded = resident;
    return n;
}

uint64_t savedSum(const std::vector<PtmNode>& nodes) {
    return std::accumulate(nodes.begin(), nodes.end(), uint64_t(0),
                           [](uint64_t s, const PtmNode& n) { return s + n.saved; });
}

TEST(StreamPolicy, NamesRoundTrip) {
    for (AllocationPolicy p : kPolicies) EXPECT_EQ(parsePolicy(policyName(p)).value(), p);
    auto bad = parsePolicy("fifo");
    ASSERT_FALSE(bad.isOk());
    EXPECT_NE(bad.status().message().find("ach, ach-return, ach-texture, lru or equal"),
              std::string::npos);
}

TEST(StreamPolicy, EqualSplitGivesEqualShares) {
    std::vector<PtmNode> nodes(4, node());
    std::vector<VisibleCell> cells = {{0, 0.9, {0, 1}}, {1, 0.1, {2, 3}}};
    // 84 / 4 = 21 = S(3) each, whatever the cells' hints.
    EXPECT_EQ(allocateEqualSplit(cells, 84, nodes), 84u);
    for (const PtmNode& n : nodes) EXPECT_EQ(n.saved, 21u);
    // 100 / 4 = 25: each share buys the same three levels; the 16 bytes left hold no level 3.
    for (PtmNode& n : nodes) n.saved = 0;
    EXPECT_EQ(allocateEqualSplit(cells, 100, nodes), 84u);
    for (const PtmNode& n : nodes) EXPECT_EQ(n.saved, 21u);
    // A node shared by two cells counts once; a node in no visible cell gets nothing.
    for (PtmNode& n : nodes) n.saved = 0;
    std::vector<VisibleCell> shared = {{0, 0.5, {0, 1}}, {1, 0.5, {1}}};
    EXPECT_EQ(allocateEqualSplit(shared, 42, nodes), 42u);
    EXPECT_EQ(nodes[0].saved, 21u);
    EXPECT_EQ(nodes[1].saved, 21u);
    EXPECT_EQ(nodes[2].saved, 0u);
}

TEST(StreamPolicy, EqualSplitWaterFillsSmallTextures) {
    std::vector<PtmNode> nodes = {node(), node(), node()};
    nodes[0].levelBytes = {1, 4};  // whole chain 5 bytes
    nodes[0].groupBytes = {10, 10};
    std::vector<VisibleCell> cells = {{0, 1.0, {0, 1, 2}}};
    // 47 / 3 = 15 for each; node 0 needs 5, so the others share 42: 21 each.
    EXPECT_EQ(allocateEqualSplit(cells, 47, nodes), 47u);
    EXPECT_EQ(nodes[0].saved, 5u);
    EXPECT_EQ(nodes[1].saved, 21u);
    EXPECT_EQ(nodes[2].saved, 21u);
    // 130: shares 5, 62 and 63 buy 5, 21 and 21 bytes of levels; the 83 bytes rounding frees
    // buy one more level of 64 for the first node that needs one.
    for (PtmNode& n : nodes) n.saved = 0;
    EXPECT_EQ(allocateEqualSplit(cells, 130, nodes), 5u + 85u + 21u);
    EXPECT_EQ(nodes[0].saved, 5u);
    EXPECT_EQ(nodes[1].saved, 85u);
    EXPECT_EQ(nodes[2].saved, 21u);
}

TEST(StreamPolicy, LruEvictsTheLeastRecentlySeen) {
    // Three full nodes (85 bytes each) seen at 2, 1 and 3 s; now node 3 comes into view and
    // wants level 0 while the budget holds 255 bytes: the node seen at 1 s loses levels first.
    std::vector<PtmNode> nodes = {node(4), node(4), node(4), node(0)};
    nodes[0].lastSeenS = 2.0, nodes[1].lastSeenS = 1.0, nodes[2].lastSeenS = 3.0;
    std::vector<VisibleCell> cells = {{0, 1.0, {3}}};
    EXPECT_EQ(allocateLru(cells, 255, nodes, 4.0), 1u + 85u + 85u + 21u);
    EXPECT_EQ(nodes[3].saved, 1u);   // the miss is served
    EXPECT_EQ(nodes[2].saved, 85u);  // seen at 3 s: kept
    EXPECT_EQ(nodes[0].saved, 85u);  // seen at 2 s: kept
    EXPECT_EQ(nodes[1].saved, 21u);  // seen at 1 s: its top level evicted
    EXPECT_EQ(nodes[3].lastSeenS, 4.0);
    // Tighter: 97 bytes. Node 3 keeps level 0 and gets level 1; the older ones are evicted from
    // the least recently seen up.
    for (PtmNode& n : nodes) n.saved = 0;
    nodes[3].resident = nodes[3].downloaded = 1;
    EXPECT_EQ(allocateLru(cells, 97, nodes, 5.0), 5u + 85u + 5u + 1u);
    EXPECT_EQ(nodes[3].saved, 5u);
    EXPECT_EQ(nodes[2].saved, 85u);
    EXPECT_EQ(nodes[0].saved, 5u);
    EXPECT_EQ(nodes[1].saved, 1u);
}

TEST(StreamPolicy, LruNeverEvictsTheWorkingSetForItself) {
    // Two nodes in view fill the budget: the second's miss waits instead of evicting the first.
    std::vector<PtmNode> nodes = {node(3), node(2)};
    std::vector<VisibleCell> cells = {{0, 1.0, {0, 1}}};
    EXPECT_EQ(allocateLru(cells, 30, nodes, 1.0), 26u);
    EXPECT_EQ(nodes[0].saved, 21u);
    EXPECT_EQ(nodes[1].saved, 5u);
    // A budget below the working set keeps whole chains in node order.
    for (PtmNode& n : nodes) n.saved = 0;
    EXPECT_EQ(allocateLru(cells, 24, nodes, 2.0), 21u + 1u);
}

// The bytes of whole levels a node's N buys: what refreshResident can make resident.
uint64_t usableBytes(const PtmNode& n) {
    int k = n.total();
    while (k > 0 && n.chainBytes(k) > n.saved) --k;
    return n.chainBytes(k);
}

TEST(StreamPolicy, AchReturnGivesTheIdleShareToTheNextCell) {
    // Two cells of equal ACH, a node each holding levels 0-1 (S(L) = 5) and wanting level 2
    // (S(L+1) = 21). Budget 30: the first cell's share is 15.
    std::vector<PtmNode> paper = {node(2), node(2)}, variant = paper;
    std::vector<VisibleCell> cells = {{0, 0.5, {0}}, {1, 0.5, {1}}};
    // The paper (6.2): 15 < 21, so node 0 saves all 15 and the second cell gets the other 15,
    // which node 1 saves too: 30 handed out, 10 usable, 20 idle for the frame.
    EXPECT_EQ(allocateBudget(cells, 30, paper), 30u);
    EXPECT_EQ(paper[0].saved, 15u);
    EXPECT_EQ(paper[1].saved, 15u);
    EXPECT_EQ(usableBytes(paper[0]) + usableBytes(paper[1]), 10u);
    // The variant: node 0 keeps its 5 bytes of whole levels and returns 10, so the second cell
    // gets 25 and node 1 its level 2; the 4 left buy no level.
    EXPECT_EQ(allocateAchReturning(cells, 30, variant), 26u);
    EXPECT_EQ(variant[0].saved, 5u);
    EXPECT_EQ(variant[1].saved, 21u);
    // Level 2 is not downloaded yet: only the variant's node 1 asks for it.
    auto always = [](uint64_t) { return true; };
    EXPECT_EQ(refreshResident(paper[1], 1000, always), RefreshAction::kNone);
    EXPECT_EQ(refreshResident(variant[1], 1000, always), RefreshAction::kDownload);
}

TEST(StreamPolicy, AchReturnOffersWhatTheLastCellLeavesAgain) {
    // Node 0 (cell of ACH 0.5) wants S(3) = 21, node 1 (ACH 0.5) only its level 0. Budget 30:
    // node 0 keeps 5 of its 15, node 1 keeps 1 of 25, and the second pass gives node 0 the 16
    // its level 2 still needs. The paper's rule: node 0 saves 15 (5 usable), node 1 keeps 1.
    std::vector<PtmNode> paper = {node(2), node(0)}, variant = paper;
    std::vector<VisibleCell> cells = {{0, 0.5, {0}}, {1, 0.5, {1}}};
    EXPECT_EQ(allocateBudget(cells, 30, paper), 16u);
    EXPECT_EQ(paper[0].saved, 15u);
    EXPECT_EQ(allocateAchReturning(cells, 30, variant), 22u);
    EXPECT_EQ(variant[0].saved, 21u);
    EXPECT_EQ(variant[1].saved, 1u);
}

TEST(StreamPolicy, AchReturnBuysAtLeastThePapersLevels) {
    // Scripted budgets over three cells of different ACH and five nodes at various levels (each
    // node in one cell): every node's whole levels under the variant hold at least what the
    // paper's rule buys it, so the usable total is never below the paper's, and all the
    // variant hands out is usable.
    std::vector<PtmNode> start = {node(0), node(1), node(2), node(3), node(4)};
    std::vector<VisibleCell> cells = {{0, 0.2, {0, 1}}, {1, 0.7, {2}}, {2, 0.1, {3, 4}}};
    uint64_t paperTotal = 0, variantTotal = 0;
    for (uint64_t budget = 0; budget <= 300; ++budget) {
        std::vector<PtmNode> paper = start, variant = start;
        allocateBudget(cells, budget, paper);
        const uint64_t used = allocateAchReturning(cells, budget, variant);
        EXPECT_LE(used, budget);
        uint64_t usable = 0;
        for (size_t n = 0; n < start.size(); ++n) {
            EXPECT_GE(usableBytes(variant[n]), usableBytes(paper[n])) << budget << " " << n;
            EXPECT_EQ(usableBytes(variant[n]), variant[n].saved) << budget << " " << n;
            paperTotal += usableBytes(paper[n]);
            variantTotal += usableBytes(variant[n]);
            usable += variant[n].saved;
        }
        EXPECT_EQ(usable, used);
    }
    EXPECT_GT(variantTotal, paperTotal);
}

TEST(StreamPolicy, TextureCoverageServesTheTexturesMostSeenFirst) {
    // Three nodes holding levels 0-2 (S(L) = 21) and wanting level 3 (S(L+1) = 85). Nodes 0 and
    // 1 are in the room of high ACH but hardly seen (hints 0.1, 0.2); node 2 is in the room of
    // low ACH and covers most of the view (0.7). Budget 180.
    std::vector<PtmNode> byCell = {node(3), node(3), node(3)}, byTexture = byCell;
    std::vector<VisibleCell> cells = {{0, 0.9, {0, 1}, {0.1, 0.2}}, {1, 0.1, {2}, {0.7}}};
    // By cells (6.1 with returns): the high-ACH room's share buys node 1 its level 3.
    EXPECT_EQ(allocateAchReturning(cells, 180, byCell), 127u);
    EXPECT_EQ(byCell[1].saved, 85u);
    EXPECT_EQ(byCell[2].saved, 21u);
    // By textures: a floor of 180 / 12 = 15 (5 kept each), then node 2's 0.7 of the 165 left
    // buys its level 3; nodes 1 and 0 keep their 21.
    EXPECT_EQ(allocateByTextureCoverage(cells, 180, byTexture), 127u);
    EXPECT_EQ(byTexture[0].saved, 21u);
    EXPECT_EQ(byTexture[1].saved, 21u);
    EXPECT_EQ(byTexture[2].saved, 85u);
}

TEST(StreamPolicy, TextureCoverageFloorKeepsUnhintedTexturesInView) {
    // Node 0 (hint 1) holds levels 0-2 and wants level 3 (85 bytes); node 1 was never seen by
    // the sampling (hint 0) and holds nothing. Budget 85: without the floor node 0 would take
    // all 85; the floor (85 / 8 = 10) keeps node 1's level 0 and leaves node 0 its 21.
    std::vector<PtmNode> nodes = {node(3), node(0)};
    std::vector<VisibleCell> cells = {{0, 1.0, {0, 1}, {1.0, 0.0}}};
    EXPECT_EQ(allocateByTextureCoverage(cells, 85, nodes), 22u);
    EXPECT_EQ(nodes[0].saved, 21u);
    EXPECT_EQ(nodes[1].saved, 1u);
    // One byte more and both fit.
    for (PtmNode& n : nodes) n.saved = 0;
    EXPECT_EQ(allocateByTextureCoverage(cells, 86, nodes), 86u);
    EXPECT_EQ(nodes[0].saved, 85u);
}

TEST(StreamPolicy, TextureCoverageWithoutHintsIsAchReturn) {
    std::vector<PtmNode> start = {node(0), node(1), node(2), node(3), node(4)};
    std::vector<VisibleCell> cells = {{0, 0.2, {0, 1}}, {1, 0.7, {2}}, {2, 0.1, {3, 4}}};
    for (uint64_t budget = 0; budget <= 300; budget += 7) {
        std::vector<PtmNode> cellWise = start, textureWise = start;
        EXPECT_EQ(allocateByTextureCoverage(cells, budget, textureWise),
                  allocateAchReturning(cells, budget, cellWise));
        for (size_t n = 0; n < start.size(); ++n)
            EXPECT_EQ(textureWise[n].saved, cellWise[n].saved);
    }
}

TEST(StreamPolicy, EveryPolicyHandsOutAtMostTheBudget) {
    std::mt19937 rng(5);
    for (int trial = 0; trial < 500; ++trial) {
        std::vector<PtmNode> nodes(1 + rng() % 12);
        for (PtmNode& n : nodes) {
            int levels = int(rng() % 6);
            for (int k = 0; k < levels; ++k) n.levelBytes.push_back(uint64_t(1) << (2 * k));
            n.groupBytes.assign(n.levelBytes.size(), 10);
            n.downloaded = levels ? int(rng() % (levels + 1)) : 0;
            n.resident = n.downloaded ? int(rng() % (n.downloaded + 1)) : 0;
            n.failed = rng() % 10 == 0;
            n.lastSeenS = double(rng() % 5);
        }
        std::vector<VisibleCell> cells(1 + rng() % 4);
        for (size_t c = 0; c < cells.size(); ++c) {
            cells[c] = {int(c), double(rng() % 100) / 100.0, {}};
            const bool hinted = rng() % 2;
            for (size_t n = 0; n < nodes.size(); ++n)
                if (rng() % 2) {
                    cells[c].nodes.push_back(int(n));
                    if (hinted) cells[c].coverage.push_back(double(rng() % 10) / 10.0);
                }
        }
        const uint64_t budget = rng() % 3000;
        for (AllocationPolicy p : kPolicies) {
            for (PtmNode& n : nodes) n.saved = 0;
            uint64_t used = allocate(p, cells, budget, nodes, 10.0);
            EXPECT_LE(used, budget) << policyName(p);
            EXPECT_EQ(savedSum(nodes), used) << policyName(p);
        }
    }
}

fs::path policyTestDir(const std::string& name) {
    fs::path dir =
        fs::path(PLX_TEST_OUTPUT_DIR) / "stream_policy" / (name + "-" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

// museum:4, quick sampling, built once; and its tour.
struct Museum {
    fs::path db;
    Cells cells;
};
const Museum& museum() {
    static const Museum m = [] {
        Museum out;
        out.db = policyTestDir("museum4");
        auto scene = scene::generateMuseum(4).value();
        out.cells = makeCells(scene).value();
        VisibilityConfig config;
        config.samples = 2;
        config.faceSize = 32;
        auto vis =
            computeVisibility(scene, out.cells, config, 0, uint32_t(out.cells.boxes.size() - 1));
        EXPECT_TRUE(vis.isOk());
        EXPECT_TRUE(
            writeDatabase(scene, out.cells, *vis, config, "museum:4", out.db.string()).isOk());
        return out;
    }();
    return m;
}

Camera cameraAt(Vec3 eye, Vec3 target) {
    CameraDesc d;
    d.eyePos = eye, d.targetPos = target, d.width = 64, d.height = 48;
    return Camera::create(d).value();
}

TEST(StreamPolicy, CapHoldsForEveryPolicyOnRandomWalks) {
    const Museum& m = museum();
    Aabb bounds;
    for (const Aabb& b : m.cells.boxes) bounds.extend(b.lo), bounds.extend(b.hi);
    std::mt19937 rng(23);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (AllocationPolicy policy : kPolicies) {
        for (uint64_t budget : {uint64_t(30) << 10, uint64_t(300) << 10, uint64_t(3) << 20}) {
            LinkSimulator link(m.db.string(),
                               {std::vector<double>{56e3, 1e6, 0.0}[rng() % 3], 0.02});
            ClientConfig config;
            config.policy = policy;
            config.budgetBytes = budget;
            config.staticBudgetBytes = budget * 3;
            config.tStaticS = 0.3;
            StreamClient client(&link, config);
            Vec3 eye = 0.5f * (m.cells.boxes[0].lo + m.cells.boxes[0].hi);
            eye.y = 1.6f;
            Vec3 target = eye + Vec3(1, 0, 0);
            uint64_t most = 0;
            for (int f = 0; f < 500; ++f) {
                if (f % 25 == 0) {
                    target = {bounds.lo.x + u(rng) * (bounds.hi.x - bounds.lo.x), eye.y,
                              bounds.lo.z + u(rng) * (bounds.hi.z - bounds.lo.z)};
                } else if ((f / 25) % 2 == 0) {
                    Vec3 step = glm::normalize(target - eye + Vec3(1e-3f)) * 0.15f;
                    eye = glm::clamp(eye + Vec3(step.x, 0.0f, step.z), bounds.lo, bounds.hi);
                }
                if (glm::length(target - eye) < 0.1f) target = eye + Vec3(1.0f, 0.0f, 0.0f);
                FrameReport r = client.frame(cameraAt(eye, target), f / 30.0);
                ASSERT_LE(r.residentBytes, r.budgetBytes) << policyName(policy) << " frame " << f;
                most = std::max(most, r.residentBytes);
            }
            EXPECT_GT(most, 0u) << policyName(policy) << " " << budget;
        }
    }
}

TEST(StreamPolicy, EveryPolicyReachesFullQualityWithRoomToSpare) {
    auto root = parseRoot([] {
                    std::ifstream in(museum().db / "root.json", std::ios::binary);
                    return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
                }())
                    .value();
    for (AllocationPolicy policy : kPolicies) {
        LinkSimulator link(museum().db.string(), {});
        ClientConfig config;
        config.policy = policy;
        config.budgetBytes = config.staticBudgetBytes = uint64_t(256) << 20;
        StreamClient client(&link, config);
        Camera cam = cameraAt(root.viewpoints[0].eyePos, root.viewpoints[0].targetPos);
        FrameReport last;
        for (int f = 0; f < 600 && last.quality < 1.0; ++f) last = client.frame(cam, f / 30.0);
        EXPECT_DOUBLE_EQ(last.quality, 1.0) << policyName(policy);
    }
}

TEST(StreamTour, VisitsEveryCellInRowsAndStopsInEach) {
    // Four rooms on a 2 x 2 grid of 10 m: centres (5,5), (15,5), (5,15), (15,15).
    std::vector<Aabb> boxes;
    for (int i = 0; i < 4; ++i) {
        Vec3 lo(float(i % 2) * 10.0f, 0.0f, float(i / 2) * 10.0f);
        boxes.push_back({lo, lo + Vec3(10.0f, 4.0f, 10.0f)});
    }
    TourConfig config;
    config.fps = 10.0, config.speedMps = 2.0, config.stopS = 1.0;
    auto tour = roomTour(boxes, config);
    ASSERT_TRUE(tour.isOk()) << tour.status().toString();
    // Three legs of 10 m at 0.2 m per pose (50 poses each) and 10 still poses at each of four.
    ASSERT_EQ(tour->size(), 3u * 50u + 4u * 10u);
    EXPECT_EQ((*tour)[0].eyePos, Vec3(5.0f, 1.6f, 5.0f));
    // Serpentine: the first row left to right, the second right to left.
    EXPECT_EQ((*tour)[10 + 50].eyePos, Vec3(15.0f, 1.6f, 5.0f));
    EXPECT_EQ((*tour)[20 + 100].eyePos, Vec3(15.0f, 1.6f, 15.0f));
    EXPECT_EQ(tour->back().eyePos, Vec3(5.0f, 1.6f, 15.0f));
    // Looking along the walk: towards -x on the last leg.
    const TourPose& p = tour->back();
    EXPECT_LT(p.targetPos.x, p.eyePos.x);
    for (const TourPose& q : *tour) EXPECT_FLOAT_EQ(glm::length(q.targetPos - q.eyePos), 5.0f);
    // No stop still visits each centre, for one frame: one cell is a tour of one pose (it was
    // none, and `stream walk --tour --stop 0` on a one-cell database crashed on it).
    config.stopS = 0.0;
    auto quick = roomTour(boxes, config);
    ASSERT_TRUE(quick.isOk());
    EXPECT_EQ(quick->size(), 3u * 50u + 4u);
    auto one = roomTour({boxes[0]}, config);
    ASSERT_TRUE(one.isOk());
    ASSERT_EQ(one->size(), 1u);
    EXPECT_EQ(one->front().eyePos, Vec3(5.0f, 1.6f, 5.0f));
}

TEST(StreamTour, RefusesWhatItCannotWalk) {
    EXPECT_FALSE(roomTour({}).isOk());
    Aabb far{Vec3(0.0f), Vec3(1.0f)}, farther{Vec3(1e9f), Vec3(1e9f + 1.0f)};
    auto huge = roomTour({far, farther});
    ASSERT_FALSE(huge.isOk());
    EXPECT_NE(huge.status().message().find("longer than"), std::string::npos);
    Aabb nan{Vec3(0.0f), Vec3(std::nanf(""))};
    EXPECT_FALSE(roomTour({nan}).isOk());
    TourConfig bad;
    bad.fps = 0.0;
    EXPECT_FALSE(roomTour({far}, bad).isOk());
    bad = {};
    bad.stopS = -1.0;
    EXPECT_FALSE(roomTour({far}, bad).isOk());
}

}  // namespace
}  // namespace plx::stream
