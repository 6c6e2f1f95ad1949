// The streaming client (Marvie & Bouatouch section 6): the 6.1/6.2 rules on scripted budgets,
// the link simulator, the glTF reader, and walks over a built museum database.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>

#include <gtest/gtest.h>

#include <plx/scene/generators.h>
#include <plx/stream/budget.h>
#include <plx/stream/cells.h>
#include <plx/stream/client.h>
#include <plx/stream/glb_reader.h>
#include <plx/stream/link_simulator.h>

namespace plx::stream {
namespace {

namespace fs = std::filesystem;

PtmNode scriptedNode(std::vector<uint64_t> levels) {
    PtmNode n;
    n.url = "textures/t00000.ptm";
    n.levelBytes = std::move(levels);
    n.groupBytes.assign(n.levelBytes.size(), 100);
    return n;
}

const auto kAllow = [](uint64_t) { return true; };
const auto kRefuse = [](uint64_t) { return false; };

TEST(StreamBudget, NodeKeepsItsShareOrReturnsIt) {
    PtmNode n = scriptedNode({1, 4, 16, 64});  // chains S: 1, 5, 21, 85
    EXPECT_EQ(offerBudget(n, 100), 1u);        // nothing resident: level 0 needs 1 byte
    n.resident = 2, n.saved = 0;
    EXPECT_EQ(offerBudget(n, 10), 10u);  // S(L+1) = 21 > 0 + 10: saves all of it
    EXPECT_EQ(offerBudget(n, 20), 11u);  // 21 <= 10 + 20: keeps what level 2 needs
    EXPECT_EQ(n.saved, 21u);
    n.resident = 4, n.saved = 0;  // top level resident: the test uses S(L) = 85
    EXPECT_EQ(offerBudget(n, 200), 85u);
    n.failed = true;
    EXPECT_EQ(offerBudget(n, 200), 0u);
}

TEST(StreamBudget, RefreshResidentFollowsThePaperOrder) {
    PtmNode n = scriptedNode({1, 4, 16, 64});
    n.downloaded = 2, n.resident = 1, n.saved = 5;
    EXPECT_EQ(refreshResident(n, 1000, kAllow), RefreshAction::kAdd);  // S(2)=5 <= 5, downloaded
    EXPECT_EQ(n.resident, 2);
    EXPECT_EQ(refreshResident(n, 1000, kAllow), RefreshAction::kNone);  // S(3)=21 > 5, S(2) = 5
    n.saved = 21;
    EXPECT_EQ(refreshResident(n, 1000, kRefuse), RefreshAction::kNone);  // dt_max refuses
    EXPECT_EQ(refreshResident(n, 1000, kAllow), RefreshAction::kDownload);
    EXPECT_TRUE(n.downloading);
    EXPECT_EQ(refreshResident(n, 1000, kAllow), RefreshAction::kNone);  // one download at a time
    n.downloading = false, n.downloaded = 3;
    EXPECT_EQ(refreshResident(n, 15, kAllow), RefreshAction::kNone);  // 16 bytes do not fit
    EXPECT_EQ(refreshResident(n, 16, kAllow), RefreshAction::kAdd);
    n.saved = 5;  // the budget shrank: one level leaves per refresh
    EXPECT_EQ(refreshResident(n, 1000, kAllow), RefreshAction::kRemove);
    EXPECT_EQ(n.resident, 2);
    n.saved = 0;
    EXPECT_EQ(refreshResident(n, 1000, kAllow), RefreshAction::kRemove);
    EXPECT_EQ(refreshResident(n, 1000, kAllow), RefreshAction::kRemove);
    EXPECT_EQ(n.resident, 0);
    EXPECT_EQ(refreshResident(n, 1000, kAllow), RefreshAction::kNone);
    n.resident = 4, n.downloaded = 4, n.saved = 1000;  // complete: nothing left to do
    EXPECT_EQ(refreshResident(n, 1000, kAllow), RefreshAction::kNone);
}

TEST(StreamBudget, CellsShareFromTheHighestAch) {
    std::vector<PtmNode> nodes = {scriptedNode({10, 40}), scriptedNode({10, 40})};
    std::vector<VisibleCell> cells = {{0, 0.25, {0}}, {1, 0.75, {1}}};
    EXPECT_EQ(allocateBudget(cells, 40, nodes), 20u);  // each keeps S(0) = 10
    for (PtmNode& n : nodes) n.saved = 0, n.resident = 1;
    // Cell 1 first: 0.75 * 40 = 30 < S(1) = 50, node 1 saves 30; cell 0 gets what is left.
    EXPECT_EQ(allocateBudget(cells, 40, nodes), 40u);
    EXPECT_EQ(nodes[1].saved, 30u);
    EXPECT_EQ(nodes[0].saved, 10u);
    // A node shared by both cells gathers from each.
    for (PtmNode& n : nodes) n.saved = 0;
    std::vector<VisibleCell> shared = {{0, 0.5, {0}}, {1, 0.5, {0}}};
    EXPECT_EQ(allocateBudget(shared, 60, nodes), 50u);
    EXPECT_EQ(nodes[0].saved, 50u);
    EXPECT_EQ(nodes[1].saved, 0u);
}

TEST(StreamBudget, BandwidthFromRecentCompletions) {
    BandwidthEstimator e(2);
    EXPECT_EQ(e.secondsFor(1000), 0.0);
    e.add(1000, 0.0, 1.0);
    EXPECT_DOUBLE_EQ(e.secondsFor(2000), 2.0);
    e.add(1000, 0.5, 3.0);  // queued behind the first until 1.0: busy 2 s
    EXPECT_DOUBLE_EQ(e.secondsFor(2000), 3.0);
    e.add(3000, 3.0, 4.0);  // the window drops the first completion
    EXPECT_DOUBLE_EQ(e.secondsFor(4000), 3.0);
}

fs::path testDir(const std::string& name) {
    // CTest runs each test in its own process, several at once: a folder per process.
    fs::path dir = fs::path(PLX_TEST_OUTPUT_DIR) / "stream_client" /
                   (name + "-" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

void writeFile(const fs::path& path, const std::string& bytes) {
    fs::create_directories(path.parent_path());
    std::ofstream(path, std::ios::binary) << bytes;
}

TEST(StreamLink, FifoLatencyAndBandwidth) {
    fs::path dir = testDir("link");
    writeFile(dir / "a" / "b.bin", std::string(1000, 'x'));
    LinkSimulator link(dir.string(), {8000.0, 0.1});  // 1000 bytes take 1 s
    link.submit({1, "a/b.bin", std::nullopt, 0}, 0.0);
    link.submit({2, "a/b.bin", ByteRange{10, 509}, 0}, 0.0);
    EXPECT_EQ(link.pending(), 2u);
    EXPECT_TRUE(link.poll(1.0).empty());
    auto first = link.poll(1.1);
    ASSERT_EQ(first.size(), 1u);
    EXPECT_TRUE(first[0].status.isOk());
    EXPECT_EQ(first[0].bytes.size(), 1000u);
    auto second = link.poll(1.75);  // 1.1 + 0.1 latency + 0.5 s
    ASSERT_EQ(second.size(), 1u);
    EXPECT_EQ(second[0].id, 2u);
    EXPECT_EQ(second[0].bytes.size(), 500u);
    EXPECT_NEAR(second[0].finishedAtS, 1.7, 1e-9);
}

TEST(StreamLink, RefusesEscapesAndInjectsFaults) {
    fs::path dir = testDir("faults");
    writeFile(dir / "f.bin", std::string(100, 'y'));
    writeFile(dir.parent_path() / "outside.bin", "secret");
    LinkSimulator link(dir.string(), {});
    for (const char* bad : {"../outside.bin", "/etc/passwd", "a//b", "missing.bin"})
        link.submit({1, bad, std::nullopt, 0}, 0.0);
    link.submit({2, "f.bin", ByteRange{200, 300}, 0}, 0.0);  // not satisfiable
    link.submit({3, "f.bin", std::nullopt, 50}, 0.0);        // over maxBytes
    for (const FetchCompletion& c : link.poll(0.0)) EXPECT_FALSE(c.status.isOk()) << c.id;
    link.injectFault(6, Fault::kTruncate);
    link.injectFault(7, Fault::kCorrupt);
    link.injectFault(8, Fault::kFail);
    for (uint64_t id = 6; id <= 8; ++id) link.submit({id, "f.bin", std::nullopt, 0}, 0.0);
    auto done = link.poll(0.0);
    ASSERT_EQ(done.size(), 3u);
    EXPECT_EQ(done[0].bytes.size(), 50u);
    EXPECT_EQ(done[1].bytes.size(), 100u);
    EXPECT_NE(done[1].bytes[50], 'y');
    EXPECT_FALSE(done[2].status.isOk());
    // A range to the end of the largest file there can be: clipped to the file, as HTTP does.
    link.submit({4, "f.bin", ByteRange{90, UINT64_MAX}, 0}, 0.0);
    auto tail = link.poll(0.0);
    ASSERT_EQ(tail.size(), 1u);
    EXPECT_TRUE(tail[0].status.isOk()) << tail[0].status.message();
    EXPECT_EQ(tail[0].bytes.size(), 10u);
}

TEST(StreamLink, OpenFetcherNamesWhatItCannotOpen) {
    auto https = openFetcher("https://127.0.0.1:8080/db", {});
    ASSERT_FALSE(https.isOk());
    EXPECT_NE(https.status().message().find("https is not supported"), std::string::npos);
    // The simulated link's shaping does not apply to a real one.
    auto shaped = openFetcher("http://127.0.0.1:8080/db", {1e6, 0.0});
    ASSERT_FALSE(shaped.isOk());
    EXPECT_NE(shaped.status().message().find("--bandwidth"), std::string::npos);
    EXPECT_FALSE(openFetcher("ftp://127.0.0.1/db", {}).isOk());
    auto http = openFetcher("http://127.0.0.1:8080/db", {});
    ASSERT_TRUE(http.isOk()) << http.status().message();
    EXPECT_TRUE((*http)->realTime());
    EXPECT_FALSE(openFetcher(testDir("empty").string(), {}).isOk());
    for (LinkOptions bad :
         {LinkOptions{std::nan(""), 0.0}, LinkOptions{0.0, -1.0}, LinkOptions{INFINITY, 0.0}})
        EXPECT_EQ(openFetcher(testDir("empty").string(), bad).status().code(),
                  ErrorCode::kInvalidArgument);
}

// A museum:4 database built once for the walks below (two samples, small faces: fast).
const fs::path& museumDb() {
    static const fs::path dir = [] {
        fs::path d = testDir("museum4");
        auto scene = scene::generateMuseum(4).value();
        auto cells = makeCells(scene).value();
        VisibilityConfig config;
        config.samples = 2;
        config.faceSize = 32;
        auto vis = computeVisibility(scene, cells, config, 0, uint32_t(cells.boxes.size() - 1));
        EXPECT_TRUE(vis.isOk());
        EXPECT_TRUE(writeDatabase(scene, cells, *vis, config, "museum:4", d.string()).isOk());
        return d;
    }();
    return dir;
}

std::vector<uint8_t> readBytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), {}};
}

TEST(StreamGlb, ReadsEveryCellAndRefusesEveryTruncatedPrefix) {
    for (uint32_t c = 0; c < 4; ++c) {
        auto cell = parseCell(readBytes(museumDb() / cellUrl(c))).value();
        auto glb = readBytes(museumDb() / geometryUrl(c));
        auto prims = parseGlb(glb);
        ASSERT_TRUE(prims.isOk()) << prims.status().toString();
        uint64_t triangles = 0;
        for (const GlbPrimitive& p : *prims) triangles += p.indices.size() / 3;
        EXPECT_EQ(triangles, cell.triangles);
        if (c > 0) continue;
        for (size_t n = 0; n < glb.size(); ++n)
            EXPECT_FALSE(parseGlb(std::span(glb.data(), n)).isOk()) << n;
        // Flipped bytes never crash the reader (and the declared length stays checked).
        std::mt19937 rng(7);
        for (int i = 0; i < 300; ++i) {
            auto bad = glb;
            bad[rng() % bad.size()] ^= uint8_t(1 + rng() % 255);
            (void)parseGlb(bad);
        }
    }
}

// A fetcher that records what the client asks for, in submission order.
class Recorder final : public Fetcher {
public:
    explicit Recorder(Fetcher* inner) : mInner(inner) {}
    void submit(FetchRequest r, double nowS) override {
        requests.push_back(r);
        mInner->submit(std::move(r), nowS);
    }
    std::vector<FetchCompletion> poll(double nowS) override { return mInner->poll(nowS); }
    size_t pending() const override { return mInner->pending(); }
    std::vector<FetchRequest> requests;

private:
    Fetcher* mInner;
};

Camera museumCamera(Vec3 eye, Vec3 target) {
    CameraDesc d;
    d.eyePos = eye, d.targetPos = target, d.width = 64, d.height = 48;
    return Camera::create(d).value();
}

Camera defaultCamera() {
    auto root = parseRoot(readBytes(museumDb() / "root.json")).value();
    return museumCamera(root.viewpoints[0].eyePos, root.viewpoints[0].targetPos);
}

TEST(StreamClient, StaticViewpointReachesFullQualityUnderTheCap) {
    LinkSimulator link(museumDb().string(), {});
    Recorder rec(&link);
    ClientConfig config;
    config.budgetBytes = config.staticBudgetBytes = uint64_t(256) << 20;
    StreamClient client(&rec, config);
    Camera cam = defaultCamera();
    FrameReport last;
    for (int f = 0; f < 600 && last.quality < 1.0; ++f) {
        last = client.frame(cam, f / 30.0);
        ASSERT_LE(last.residentBytes, last.budgetBytes);
    }
    EXPECT_DOUBLE_EQ(last.quality, 1.0);
    // The renderer's scene carries the resident textures, each at its highest resident level.
    auto drawn = client.residentScene();
    ASSERT_TRUE(drawn.isOk()) << drawn.status().toString();
    ASSERT_FALSE(drawn->textures.empty());
    for (const scene::Texture& t : drawn->textures) EXPECT_GT(t.width(), 1);
    EXPECT_EQ(client.failedRequests(), 0u) << (client.log().empty() ? "" : client.log()[0]);
    // Cells and geometry of the first cell's PVS went out before any texture level.
    size_t lastGeometry = 0, firstLevel = rec.requests.size();
    for (size_t i = 0; i < rec.requests.size(); ++i) {
        const FetchRequest& r = rec.requests[i];
        if (r.path.ends_with(".glb") && i < firstLevel) lastGeometry = i;
        if (r.range && r.range->first > 0) firstLevel = std::min(firstLevel, i);
    }
    EXPECT_LT(lastGeometry, firstLevel);
    EXPECT_LT(firstLevel, rec.requests.size());
}

TEST(StreamClient, CapHoldsOnRandomWalks) {
    auto root = parseRoot(readBytes(museumDb() / "root.json")).value();
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    for (uint64_t budget : {uint64_t(20) << 10, uint64_t(200) << 10, uint64_t(2) << 20}) {
        double bits = std::vector<double>{56e3, 1e6, 10e6, 0.0}[rng() % 4];
        LinkSimulator link(museumDb().string(), {bits, 0.02});
        ClientConfig config;
        config.budgetBytes = budget;
        config.staticBudgetBytes = budget * 2;
        config.tStaticS = 0.2;
        StreamClient client(&link, config);
        Vec3 lo = root.boundsMin, hi = root.boundsMax;
        Vec3 eye = root.viewpoints[0].eyePos, target = root.viewpoints[0].targetPos;
        uint64_t most = 0;
        for (int f = 0; f < 400; ++f) {
            if (f % 20 == 0) {  // a new random heading; every other leg stands still
                target = {lo.x + u(rng) * (hi.x - lo.x), eye.y, lo.z + u(rng) * (hi.z - lo.z)};
            } else if ((f / 20) % 2 == 0) {
                Vec3 step = glm::normalize(target - eye + Vec3(1e-3f)) * 0.1f;
                eye = glm::clamp(eye + Vec3(step.x, 0.0f, step.z), lo, hi);
            }
            if (glm::length(target - eye) < 0.1f) target = eye + Vec3(1.0f, 0.0f, 0.0f);
            FrameReport r = client.frame(museumCamera(eye, target), f / 30.0);
            ASSERT_LE(r.residentBytes, r.budgetBytes) << "frame " << f;
            most = std::max(most, r.residentBytes);
        }
        EXPECT_GT(most, 0u) << budget;
    }
}

TEST(StreamClient, HostileCompletionsAreRetriedOrSkipped) {
    // A clean run finds which submissions are level groups; the same deterministic run then gets
    // one truncated, one corrupt and one failed level, a failed root and a corrupt header.
    ClientConfig config;
    config.budgetBytes = config.staticBudgetBytes = uint64_t(256) << 20;
    std::vector<size_t> levels, headers;
    {
        LinkSimulator link(museumDb().string(), {});
        Recorder rec(&link);
        StreamClient client(&rec, config);
        for (int f = 0; f < 30; ++f) (void)client.frame(defaultCamera(), f / 30.0);
        for (size_t i = 0; i < rec.requests.size(); ++i) {
            const FetchRequest& r = rec.requests[i];
            if (r.range && r.range->first > 0) levels.push_back(i);
            if (r.range && r.range->first == 0) headers.push_back(i);
        }
    }
    ASSERT_GE(levels.size(), 3u);
    ASSERT_GE(headers.size(), 1u);
    LinkSimulator link(museumDb().string(), {});
    link.injectFault(0, Fault::kFail);  // the root, retried
    link.injectFault(1 + headers[0], Fault::kCorrupt);
    link.injectFault(1 + levels[0], Fault::kTruncate);
    link.injectFault(1 + levels[1], Fault::kCorrupt);
    link.injectFault(1 + levels[2], Fault::kFail);
    // Retries shift later submissions, so several faults may hit one texture: allow enough.
    config.maxRetries = 5;
    StreamClient client(&link, config);
    FrameReport last;
    for (int f = 0; f < 900 && last.quality < 1.0; ++f)
        last = client.frame(defaultCamera(), f / 30.0);
    EXPECT_DOUBLE_EQ(last.quality, 1.0);
    EXPECT_GE(client.failedRequests(), 4u);
    ASSERT_FALSE(client.log().empty());
    EXPECT_NE(client.log()[0].find("retrying"), std::string::npos) << client.log()[0];
    // Each line names its request once, with its byte range: the fetcher's failures (the root's
    // injected one) as well as the client's own (a corrupt header).
    for (const std::string& line : client.log()) {
        const std::string path = line.substr(0, line.find_first_of(" :"));
        EXPECT_EQ(line.find(path, 1), std::string::npos) << line;
        if (path != "root.json") {
            EXPECT_NE(line.find(" bytes "), std::string::npos) << line;
        }
    }

    // Every request failing: the client gives up on the root and frames go on.
    config.maxRetries = 2;
    LinkSimulator dead(museumDb().string(), {});
    for (uint64_t i = 0; i < 10; ++i) dead.injectFault(i, Fault::kFail);
    StreamClient stuck(&dead, config);
    for (int f = 0; f < 30; ++f) (void)stuck.frame(defaultCamera(), f / 30.0);
    EXPECT_TRUE(stuck.rootFailed());
    EXPECT_EQ(stuck.failedRequests(), uint64_t(config.maxRetries + 1));
}

}  // namespace
}  // namespace plx::stream
