// parallax stream walk run as a user would: the JSON summary, the cap against the budget, full
// quality with a static viewpoint on an unlimited link, one-line errors.

#include <unistd.h>

#include <fstream>
#include <set>

#include <nlohmann/json.hpp>

#include "cli_runner.h"

namespace {

using namespace plx::testing;

// A museum:4 database with a quick sampling, built once.
const fs::path& walkDb() {
    static const fs::path dir = [] {
        // One database per test process (CTest runs several at once).
        fs::path d = scratchDir("stream_walk_cli") / ("db-" + std::to_string(getpid()));
        fs::remove_all(d);
        RunResult r =
            runParallax("stream build museum:4 --samples 2 --face-size 32 --out " + d.string());
        EXPECT_EQ(r.exitCode, 0) << r.err;
        return d;
    }();
    return dir;
}

TEST(StreamWalkCli, JsonSummaryAndTheCap) {
    RunResult r = runParallax("stream walk " + walkDb().string() +
                              " --walk 90 --bandwidth 1000 --latency 20 --budget 0.25 --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    for (const char* key : {"frames", "budget_bytes", "max_resident_bytes", "downloaded_bytes",
                            "quality_final", "failed_requests", "per_frame"})
        EXPECT_TRUE(doc.contains(key)) << key;
    EXPECT_EQ(doc["frames"], 90);
    EXPECT_EQ(doc["budget_bytes"], 262144);
    ASSERT_EQ(doc["per_frame"].size(), 90u);
    for (const auto& f : doc["per_frame"])
        EXPECT_LE(f["resident_bytes"].get<uint64_t>(), f["budget_bytes"].get<uint64_t>());
    EXPECT_GT(doc["downloaded_bytes"].get<uint64_t>(), 0u);
}

TEST(StreamWalkCli, StaticViewpointReachesFullQuality) {
    // One pose held for four simulated seconds: the static budget and dt_max take over.
    fs::path path = scratchDir("stream_walk_cli") / "still.json";
    std::ifstream in(walkDb() / "root.json");
    auto root = nlohmann::json::parse(in);
    auto v = root["viewpoints"][0];
    nlohmann::json poses = nlohmann::json::array();
    for (int i = 0; i < 120; ++i) poses.push_back({{"eye", v["eye"]}, {"target", v["target"]}});
    writeFile(path, poses.dump());
    RunResult r = runParallax("stream walk " + walkDb().string() + " --path " + path.string() +
                              " --static-budget 256 --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["quality_final"], 1.0);
    EXPECT_EQ(doc["failed_requests"], 0);
}

// The tour through every room (section 7.1): four rooms, 2 s still in each, under each policy.
// The paper's allocation and the one reading the database's texture coverage hints; every
// policy's cap on random walks is StreamPolicy.CapHoldsForEveryPolicyOnRandomWalks.
TEST(StreamWalkCli, TourThroughEveryRoom) {
    for (const char* policy : {"ach", "ach-texture"}) {
        RunResult r = runParallax("stream walk " + walkDb().string() +
                                  " --tour --stop 2 --size 64x48 --budget 0.25 --static-budget 0.5"
                                  " --policy " +
                                  policy + " --json");
        ASSERT_EQ(r.exitCode, 0) << r.err;
        auto doc = nlohmann::json::parse(r.out);
        EXPECT_EQ(doc["policy"], policy);
        // museum:4 is 2 x 2 rooms of 10 m: three legs of 10 m at 1.2 m/s (250 frames each at
        // 30 fps) and 60 still frames in each room.
        EXPECT_EQ(doc["frames"], 3 * 250 + 4 * 60);
        std::set<int> cells;
        for (const auto& f : doc["per_frame"]) {
            // null for the frames before the first cell arrived
            if (!f["cell"].is_null()) cells.insert(f["cell"].get<int>());
            EXPECT_LE(f["resident_bytes"].get<uint64_t>(), f["budget_bytes"].get<uint64_t>());
        }
        EXPECT_EQ(cells, (std::set<int>{0, 1, 2, 3}));
    }
}

// A texture URL that leaves the database is skipped with a warning, and --strict makes the
// warning an error (it was swallowed there: exit 0 and nothing said).
TEST(StreamWalkCli, StrictTurnsSkippedTexturesIntoAnError) {
    const fs::path db = scratchDir("stream_walk_cli") / ("evil-" + std::to_string(getpid()));
    fs::remove_all(db);
    fs::copy(walkDb(), db, fs::copy_options::recursive);
    const fs::path cell = db / "cells" / "c00000.json";
    nlohmann::json doc = nlohmann::json::parse(std::ifstream(cell));
    ASSERT_FALSE(doc["textures"].empty());
    doc["textures"][0]["url"] = "../../../../etc/passwd";
    writeFile(cell, doc.dump());
    const std::string walk = "stream walk " + db.string() + " --walk 30 --size 80x60";
    RunResult lenient = runParallax(walk);
    EXPECT_EQ(lenient.exitCode, 0) << lenient.err;
    EXPECT_NE(lenient.err.find("parallax: warning:"), std::string::npos) << lenient.err;
    expectOneLineError(runParallax("--strict " + walk), "(an error with --strict)");
}

TEST(StreamWalkCli, BadArgumentsAreOneLineErrors) {
    const std::string db = walkDb().string();
    expectOneLineError(runParallax("stream walk " + db), "--walk N or --tour", 2);
    expectOneLineError(runParallax("stream walk " + db + " --tour --walk 5"), "exclude", 2);
    expectOneLineError(runParallax("stream walk " + db + " --tour --stop -1"), "--stop", 2);
    expectOneLineError(runParallax("stream walk " + db + " --walk 5 --policy fifo"), "policy", 2);
    expectOneLineError(runParallax("stream walk " + db + " --walk 0"), "--walk", 2);
    expectOneLineError(runParallax("stream walk " + db + " --walk -1"), "--walk -1", 2);
    expectOneLineError(runParallax("stream walk " + db + " --walk 5 --budget -1"), "--budget", 2);
    expectOneLineError(runParallax("stream walk " + db + " --walk 5 --fps 0"), "--fps", 2);
    expectOneLineError(runParallax("stream walk " + db + " --walk 5 --size 0x3"), "size", 2);
    // Nothing listens on port 1: the root request fails after its bounded tries.
    expectOneLineError(runParallax("stream walk http://127.0.0.1:1/db --walk 5"), "root.json");
    expectOneLineError(runParallax("stream walk http://127.0.0.1:1/db --walk 5 --bandwidth 56"),
                       "--bandwidth");
    expectOneLineError(runParallax("stream walk /nonexistent/db --walk 5"),
                       "not a stream database");
    fs::path bad = scratchDir("stream_walk_cli") / "bad.json";
    writeFile(bad, "[{\"eye\": [0, 1]}]");
    expectOneLineError(runParallax("stream walk " + db + " --path " + bad.string()), "pose");
}

}  // namespace
