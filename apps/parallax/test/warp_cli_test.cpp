// parallax warp and bench warp run as a user would: the JSON fields, the quality ordering of
// small and large moves, one-line errors for bad parameters.

#include <nlohmann/json.hpp>

#include "cli_runner.h"

namespace {

using namespace plx::testing;

fs::path warpDir() {
    return plx::testing::scratchDir("warp_cli");
}

// office:2's default viewpoint, written out so the moves below are relative to a known pose.
const std::string kFrom = " --eye 1.0,1.6,1.0 --target 4.0,1.2,5.0 --size 160x120";

nlohmann::json warpJson(const std::string& toEye, const std::string& name) {
    fs::path prefix = warpDir() / name;
    RunResult r = runParallax("warp office:2" + kFrom + " --to-eye " + toEye +
                              " --frames 2 --out " + prefix.string() + " --json");
    EXPECT_EQ(r.exitCode, 0) << r.err;
    if (r.exitCode != 0) return {};
    for (const char* suffix : {"-warped.png", "-truth.png", "-diff.png"})
        EXPECT_TRUE(fs::exists(prefix.string() + suffix)) << suffix;
    return nlohmann::json::parse(r.out);
}

TEST(WarpCli, JsonFieldsAndQualityFallWithTheMove) {
    nlohmann::json same = warpJson("1.0,1.6,1.0", "same");
    nlohmann::json small = warpJson("1.05,1.6,1.05", "small");
    nlohmann::json large = warpJson("1.8,1.6,1.9", "large");
    ASSERT_FALSE(same.is_null() || small.is_null() || large.is_null());
    for (const char* key : {"warp_ms", "mpix_per_s", "rows_clipped", "hole_fraction", "psnr_db",
                            "refs", "splat", "size", "source_pixels", "warped_pixels", "outputs"})
        EXPECT_TRUE(small.contains(key)) << key;
    EXPECT_EQ(small["refs"], "cube4");
    EXPECT_EQ(small["splat"], "derivative");
    EXPECT_EQ(small["size"], "160x120");
    EXPECT_GT(small["warp_ms"].get<double>(), 0.0);
    EXPECT_GT(small["mpix_per_s"].get<double>(), 0.0);
    EXPECT_LT(small["warped_pixels"].get<int64_t>(), small["source_pixels"].get<int64_t>());
    // cube4 puts three faces at least partly behind or beside the view: rows get clipped.
    EXPECT_GT(small["rows_clipped"].get<int>(), 0);
    for (const auto* doc : {&same, &small, &large}) {
        EXPECT_GE((*doc)["hole_fraction"].get<double>(), 0.0);
        EXPECT_LE((*doc)["hole_fraction"].get<double>(), 1.0);
    }
    EXPECT_GT(same["psnr_db"].get<double>(), 30.0);
    EXPECT_GT(same["psnr_db"].get<double>(), small["psnr_db"].get<double>());
    EXPECT_GT(small["psnr_db"].get<double>(), large["psnr_db"].get<double>());
    EXPECT_LE(same["hole_fraction"].get<double>(), large["hole_fraction"].get<double>());
}

TEST(WarpCli, EveryLayoutAndSplatRuns) {
    for (const char* refs : {"cube4", "cube6", "wide"})
        for (const char* splat : {"derivative", "point", "fixed", "mesh"}) {
            fs::path prefix = warpDir() / (std::string(refs) + "_" + splat);
            RunResult r =
                runParallax(std::string("warp office:1 --size 48x36 --to-eye 1.1,1.6,1.1 "
                                        "--frames 1 --refs ") +
                            refs + " --splat " + splat + " --out " + prefix.string() + " --json");
            ASSERT_EQ(r.exitCode, 0) << refs << " " << splat << ": " << r.err;
            auto doc = nlohmann::json::parse(r.out);
            EXPECT_EQ(doc["refs"], refs);
            EXPECT_EQ(doc["splat"], splat);
            EXPECT_GT(doc["psnr_db"].get<double>(), 10.0) << refs << " " << splat;
        }
}

TEST(WarpCli, FirstPoseFromANamedViewpoint) {
    fs::path prefix = warpDir() / "vista";
    RunResult r = runParallax(
        "warp office:2 --viewpoint vista --size 48x36 --to-eye 0.6,1.6,0.6 "
        "--frames 1 --out " +
        prefix.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_GT(nlohmann::json::parse(r.out)["psnr_db"].get<double>(), 10.0);
    expectOneLineError(
        runParallax("warp office:2 --viewpoint nowhere --to-eye 1,1,1 --out " + prefix.string()),
        "nowhere", 2);
}

TEST(WarpCli, BadParametersGiveOneLineErrors) {
    std::string out = " --out " + (warpDir() / "bad").string();
    std::string base = "warp office:1 --size 32x24";
    expectOneLineError(runParallax(base + " --to-eye nan,1,1" + out), "nan", 2);
    expectOneLineError(runParallax(base + " --to-eye 1,1,1 --to-target 1,inf,2" + out),
                       "--to-target", 2);
    expectOneLineError(runParallax(base + " --eye 1,nan,1 --target 2,1,2 --to-eye 1,1,1" + out),
                       "--eye", 2);
    expectOneLineError(runParallax("warp office:1 --size 0x24 --to-eye 1,1,1" + out), "0x24", 2);
    expectOneLineError(runParallax(base + " --to-eye 1,1,1 --splat blob" + out), "blob", 2);
    expectOneLineError(runParallax(base + " --to-eye 1,1,1 --refs sphere" + out), "sphere", 2);
    expectOneLineError(runParallax(base + " --to-eye 1,1,1 --frames 0" + out), "--frames", 2);
    expectOneLineError(runParallax(base + out), "--to-eye", 2);
    expectOneLineError(runParallax(base + " --eye 1,1.6,1 --target 3,1.6,3 --to-eye 3,1.6,3" + out),
                       "--to-eye", 2);
    expectOneLineError(runParallax("warp no_such_file.glb --to-eye 1,1,1" + out),
                       "no_such_file.glb");
}

TEST(WarpCli, BenchWarpQuickHasEveryMethodAtEveryRtt) {
    fs::path dir = warpDir() / "bench";
    RunResult r = runParallax("bench warp --quick --out " + dir.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    const std::vector<double> rtts = doc["rtts_ms"].get<std::vector<double>>();
    ASSERT_FALSE(rtts.empty());
    for (const char* method :
         {"stale", "timewarp", "warp1", "warp2", "warp2_predicted", "warp2_bracketed"})
        for (double rtt : rtts) {
            int found = 0;
            for (const auto& row : doc["rows"])
                if (row["method"] == method && row["rtt_ms"].get<double>() == rtt) {
                    ++found;
                    for (const char* key :
                         {"scene", "psnr_db_median", "hole_fraction_median", "warp_ms_median"})
                        EXPECT_TRUE(row.contains(key)) << key;
                    EXPECT_GT(row["psnr_db_median"].get<double>(), 5.0);
                    // The stale frame is not warped: no time, rather than a 0 that reads as one.
                    if (row["method"] == "stale")
                        EXPECT_TRUE(row["warp_ms_median"].is_null());
                    else
                        EXPECT_GT(row["warp_ms_median"].get<double>(), 0.0);
                }
            EXPECT_EQ(found, 1) << method << " at " << rtt << " ms";
        }
    EXPECT_FALSE(doc["throughput"].empty());
    EXPECT_TRUE(fs::exists(dir / "latency.csv"));
    EXPECT_TRUE(fs::exists(dir / "throughput.csv"));
    EXPECT_TRUE(fs::exists(dir / "psnr_vs_rtt_office_2.svg"));
    expectOneLineError(runParallax("bench warp --quick --rtts=-5 --out " + dir.string()), "RTT", 2);
    expectOneLineError(runParallax("bench warp --quick --splat blob --out " + dir.string()), "blob",
                       2);
}

}  // namespace
