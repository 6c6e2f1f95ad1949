// parallax bench stream run as a user would: the JSON rows of the section-7 walks and of the
// allocation comparison on a tiny quick setting, the files it writes, one-line errors.

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "cli_runner.h"

namespace {

using namespace plx::testing;

TEST(StreamBenchCli, QuickJsonRowsAndOrderByBandwidth) {
    fs::path dir = scratchDir("stream_bench_cli") / ("quick-" + std::to_string(getpid()));
    RunResult r = runParallax(
        "bench stream --quick --bandwidths 56,1000,0 --policy-budgets "
        "0.125 --stop 1 --no-frame-times --json --out " +
        dir.string());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    const auto& walks = doc["walks"];
    ASSERT_EQ(walks.size(), 3u);
    for (size_t i = 0; i < walks.size(); ++i) {
        for (const char* key : {"bandwidth_kbit", "quality_final", "time_to_quality_90_s",
                                "max_resident_bytes", "budget_bytes", "frames_over_budget"})
            EXPECT_TRUE(walks[i].contains(key)) << key;
        const auto& at90 = walks[i]["time_to_quality_90_s"];  // null: never reached
        EXPECT_TRUE(at90.is_null() || at90.get<double>() >= 0.0) << at90;
        EXPECT_LE(walks[i]["max_resident_bytes"], walks[i]["budget_bytes"]);
        EXPECT_EQ(walks[i]["frames_over_budget"], 0);
        // Fig. 2: the curves order by bandwidth (56 kbit/s, 1 Mbit/s, unlimited).
        if (i > 0) {
            EXPECT_GE(walks[i]["quality_final"], walks[i - 1]["quality_final"]);
        }
    }
    EXPECT_EQ(walks[0]["bandwidth_kbit"], 56.0);
    EXPECT_GT(walks.back()["quality_final"], walks.front()["quality_final"]);
    const auto& policies = doc["policies"];
    ASSERT_EQ(policies.size(), 5u);
    for (const auto& p : policies) {
        EXPECT_EQ(p["budget_bytes"], 131072);
        EXPECT_LE(p["max_resident_bytes"], p["budget_bytes"]);
        EXPECT_GT(p["frames_compared"].get<int>(), 0);
        EXPECT_GT(p["psnr_db"].get<double>(), 10.0);
        // The frames after the first stop are fewer and past the start-up load.
        EXPECT_GE(p["psnr_after_first_stop_db"].get<double>(), p["psnr_db"].get<double>() - 3.0);
        // Named as client and bench warp and remote name their median PSNR.
        EXPECT_GT(p["psnr_db_median"].get<double>(), 10.0);
    }
    EXPECT_FALSE(doc.contains("frame_time"));  // --no-frame-times
    for (const char* file :
         {"stream.json", "walks.csv", "policies.csv", "policy_frames.csv", "stream_quality.svg",
          "stream_resident.svg", "stream_policies.svg", "stream_10s.png"})
        EXPECT_TRUE(fs::exists(dir / file)) << file;
}

TEST(StreamBenchCli, BadArgumentsAreOneLineErrors) {
    const std::string out = " --out " + (scratchDir("stream_bench_cli") / "bad").string();
    expectOneLineError(runParallax("bench stream --quick --bandwidths -5" + out), "bandwidth", 2);
    expectOneLineError(runParallax("bench stream --quick --policy-budgets 0" + out),
                       "--policy-budgets", 2);
    expectOneLineError(runParallax("bench stream --quick --budget nan" + out), "--budget", 2);
    expectOneLineError(runParallax("bench stream --quick --size 3x3" + out), "size", 2);
    expectOneLineError(runParallax("bench stream --quick --stop -2" + out), "--stop", 2);
    expectOneLineError(runParallax("bench stream --quick --samples 0" + out), "--samples", 2);
    // The values that once stood for "the default" are refused like their neighbours.
    expectOneLineError(runParallax("bench stream --quick --stop -1" + out), "--stop -1", 2);
    expectOneLineError(runParallax("bench stream --quick --samples -1" + out), "--samples -1", 2);
    expectOneLineError(runParallax("bench stream --quick --budget 0" + out), "--budget 0", 2);
    expectOneLineError(runParallax("bench stream --quick --static-budget 0" + out),
                       "--static-budget 0", 2);
    expectOneLineError(runParallax("bench stream --quick --latency nan" + out),
                       "--latency: 'nan' is not a finite number", 2);
    expectOneLineError(runParallax("bench warp --quick --duration 0" + out), "duration 0 s", 2);
    expectOneLineError(runParallax("bench stream --quick --scene office:0" + out), "office");
}

}  // namespace
