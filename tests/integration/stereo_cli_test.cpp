// parallax stereo and bench stereo run as a user would.

#include <nlohmann/json.hpp>

#include <plx/core/image_io.h>

#include "cli_runner.h"

namespace {

using namespace plx::testing;

fs::path stereoDir() {
    return plx::testing::scratchDir("stereo_cli");
}

TEST(StereoCli, PBufferPairJsonAndLayouts) {
    fs::path prefix = stereoDir() / "pair";
    // "+0.065": a leading '+', as strtod reads it.
    RunResult r = runParallax(
        "stereo office:4 --method pbuffer --size 96x72 --frames 2 "
        "--separation +0.065 --out " +
        prefix.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    for (const char* key : {"method", "triangles", "visible_triangles", "first_eye_ms",
                            "second_eye_ms", "pair_ms", "second_eye_psnr_db"})
        EXPECT_TRUE(doc.contains(key)) << key;
    EXPECT_EQ(doc["method"], "pbuffer");
    // The float options as written (0.065, not the float's 0.06499999761581421).
    EXPECT_EQ(doc["separation"].get<double>(), 0.065);
    EXPECT_EQ(doc["convergence"].get<double>(), 3.0);
    EXPECT_GT(doc["second_eye_psnr_db"].get<double>(), 20.0);
    EXPECT_EQ(doc["frames"], 2);
    EXPECT_GT(doc["identical_fraction"].get<double>(), 0.9);
    EXPECT_LE(doc["identical_fraction"].get<double>(), 1.0);
    EXPECT_LT(doc["visible_triangles"].get<int>(), doc["triangles"].get<int>());
    EXPECT_TRUE(fs::exists(prefix.string() + ".left.png"));
    EXPECT_TRUE(fs::exists(prefix.string() + ".right.png"));
    EXPECT_TRUE(fs::exists(prefix.string() + ".diff.png"));
    for (const char* format : {"sbs", "tb", "anaglyph", "interleaved"}) {
        fs::path p = stereoDir() / format;
        RunResult f =
            runParallax(std::string("stereo office:1 --method full --size 32x24 --format ") +
                        format + " --out " + p.string());
        ASSERT_EQ(f.exitCode, 0) << f.err;
        EXPECT_TRUE(fs::exists(p.string() + "." + format + ".png")) << format;
    }
}

TEST(StereoCli, ReprojectPairJsonHasHolesAndQuality) {
    // 640x480: at smaller sizes the half-pixel shifts of reprojected polygon edges alone make
    // more than 1% of the pixels differ from the full render.
    fs::path prefix = stereoDir() / "reproject";
    RunResult r = runParallax(
        "stereo office:1 --method reproject --shading flat --size 640x480 "
        "--frames 2 --threads 2 --out " +
        prefix.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    for (const char* key :
         {"hole_pixels", "expansion_holes", "disocclusion_holes", "fill_polygons_tested",
          "fill_polygons_drawn", "reproject_ms", "fill_ms", "identical_fraction", "frames",
          "prepare_ms", "second_eye_psnr_db", "unseen_pixels", "unseen_triangles"})
        EXPECT_TRUE(doc.contains(key)) << key;
    EXPECT_EQ(doc["method"], "reproject");
    EXPECT_EQ(doc["frames"], 2);
    const double identical = doc["identical_fraction"].get<double>();
    EXPECT_GE(identical, 0.99);
    EXPECT_LE(identical, 1.0);
    EXPECT_GE(doc["hole_pixels"].get<int64_t>(), 0);
    EXPECT_LE(doc["hole_pixels"].get<int64_t>(), 640 * 480);
    EXPECT_GE(doc["fill_polygons_tested"].get<int64_t>(),
              doc["fill_polygons_drawn"].get<int64_t>());
    EXPECT_GT(doc["second_eye_ms"].get<double>(), 0.0);
    EXPECT_GE(doc["prepare_ms"].get<double>(), 0.0);
    EXPECT_GT(doc["visible_triangles"].get<int>(), 0);
    EXPECT_GT(doc["second_eye_psnr_db"].get<double>(), 30.0);
    for (const char* suffix : {".left.png", ".right.png", ".diff.png"})
        EXPECT_TRUE(fs::exists(prefix.string() + suffix)) << suffix;
}

TEST(StereoCli, ReprojectWithLayoutsRigsAndWalkthroughs) {
    for (const char* format : {"sbs", "anaglyph"}) {
        fs::path p = stereoDir() / (std::string("reproject_") + format);
        RunResult f = runParallax(std::string("stereo office:1 --method reproject --size 48x32 "
                                              "--frames 1 --first-eye right --rig parallel "
                                              "--format ") +
                                  format + " --out " + p.string());
        ASSERT_EQ(f.exitCode, 0) << f.err;
        EXPECT_TRUE(fs::exists(p.string() + "." + format + ".png")) << format;
    }
    fs::path prefix = stereoDir() / "reproject_walk";
    RunResult r = runParallax(
        "stereo office:2 --method reproject --reproject-lut --surrounding-first --walk 2 "
        "--size 48x32 --frames 1 --out " +
        prefix.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["poses"], 2);
    EXPECT_TRUE(doc["reproject_lut"].get<bool>());
    EXPECT_TRUE(doc["surrounding_first"].get<bool>());
    ASSERT_EQ(doc["per_pose"].size(), 2u);
    EXPECT_TRUE(doc["per_pose"][1].contains("hole_pixels"));
    EXPECT_TRUE(fs::exists(prefix.string() + "_0001.left.png"));
    // The files written, as for a single pose: a list, each pose's two eyes.
    ASSERT_TRUE(doc["outputs"].is_array());
    EXPECT_EQ(doc["outputs"].size(), 4u);
    EXPECT_EQ(doc["outputs"][2], prefix.string() + "_0001.left.png");
}

// The two disocclusion searches give the same pixels (fill.h); the default builds no BSP tree.
TEST(StereoCli, FillSearchesGiveTheSamePictures) {
    std::string pictures[2];
    for (int i = 0; i < 2; ++i) {
        const std::string search = i == 0 ? "boxes" : "bsp";
        const fs::path prefix = stereoDir() / ("search_" + search);
        RunResult r =
            runParallax("stereo office:2 --method reproject --size 160x120 --frames 1 --out " +
                        prefix.string() + (i == 0 ? "" : " --fill-search bsp") + " --json");
        ASSERT_EQ(r.exitCode, 0) << r.err;
        auto doc = nlohmann::json::parse(r.out);
        EXPECT_EQ(doc["fill_search"], search);
        EXPECT_GT(doc["disocclusion_holes"].get<int>(), 0);
        for (const char* suffix : {".right.png", ".diff.png"}) {
            auto bytes = plx::readFileBytes(prefix.string() + suffix);
            ASSERT_TRUE(bytes.isOk()) << bytes.status().message();
            pictures[i].append(bytes->begin(), bytes->end());
        }
    }
    EXPECT_EQ(pictures[0], pictures[1]);
}

TEST(StereoCli, WalkthroughReportsPerPoseTimings) {
    fs::path prefix = stereoDir() / "walk";
    RunResult r = runParallax("stereo office:2 --walk 3 --size 48x32 --conservative --out " +
                              prefix.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["poses"], 3);
    EXPECT_EQ(doc["frames"], 9);  // timed pairs per pose, the default
    EXPECT_EQ(doc["per_pose"].size(), 3u);
    EXPECT_TRUE(fs::exists(prefix.string() + "_0002.left.png"));
    fs::path path = stereoDir() / "path.json";
    writeFile(
        path,
        R"({"poses":[{"eye":[1,1.6,1],"target":[5,1,5]},{"eye":[1.2,1.6,1],"target":[5,1,5]}]})");
    r = runParallax("stereo office:1 --path " + path.string() + " --size 32x24 --out " +
                    (stereoDir() / "p").string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["poses"], 2);
}

TEST(StereoCli, BadParametersGiveOneLineErrors) {
    std::string out = " --out " + (stereoDir() / "bad").string();
    expectOneLineError(runParallax("stereo office:1 --separation -0.1" + out), "separation", 2);
    expectOneLineError(runParallax("stereo office:1 --convergence 0" + out), "convergence", 2);
    expectOneLineError(runParallax("stereo office:1 --method magic" + out), "magic", 2);
    for (const char* method : {"full", "pbuffer", "reproject"})
        expectOneLineError(runParallax("stereo office:1 --method bogus" + out), method, 2);
    expectOneLineError(runParallax("stereo office:1 --method reproject --conservative" + out),
                       "--conservative", 2);
    expectOneLineError(runParallax("stereo office:1 --method pbuffer --reproject-lut" + out),
                       "--reproject-lut", 2);
    expectOneLineError(runParallax("stereo office:1 --method full --surrounding-first" + out),
                       "--surrounding-first", 2);
    expectOneLineError(runParallax("stereo office:1 --method pbuffer --fill-search bsp" + out),
                       "--fill-search", 2);
    expectOneLineError(runParallax("stereo office:1 --method reproject --fill-search octree" + out),
                       "octree", 2);
    expectOneLineError(runParallax("stereo office:1 --format hologram" + out), "hologram", 2);
    expectOneLineError(runParallax("stereo office:1 --rig sideways" + out), "sideways", 2);
    for (const char* frames : {"0", "-1", "abc", "100001"})
        expectOneLineError(runParallax(std::string("stereo office:1 --frames ") + frames + out),
                           "--frames", 2);
    fs::path bad = stereoDir() / "bad_path.json";
    writeFile(bad, R"({"poses":[{"eye":[0,1,0]}]})");
    expectOneLineError(runParallax("stereo office:1 --path " + bad.string() + out), "target");
}

TEST(StereoCli, BenchStereoWritesTableAndPlots) {
    fs::path dir = stereoDir() / "bench";
    RunResult r = runParallax("bench stereo --rooms 1,2 --size 64x48 --frames 1 --out " +
                              dir.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    ASSERT_EQ(doc["rows"].size(), 2u);
    EXPECT_EQ(doc["separation"].get<double>(), 0.065);
    for (const auto& row : doc["rows"]) {
        for (const char* key : {"reproject_first_ms", "reproject_second_ms", "reproject_psnr_db"})
            EXPECT_GT(row[key].get<double>(), 0.0) << key;
        EXPECT_GT(row["reproject_pair_speedup"].get<double>(), 0.0);
        for (const char* key : {"reproject_identical_fraction", "reproject_hole_fraction"}) {
            EXPECT_GE(row[key].get<double>(), 0.0) << key;
            EXPECT_LE(row[key].get<double>(), 1.0) << key;
        }
    }
    EXPECT_TRUE(fs::exists(dir / "table1.csv"));
    EXPECT_TRUE(fs::exists(dir / "methods.md"));
    EXPECT_TRUE(fs::exists(dir / "reproject_paper_table.md"));
    EXPECT_TRUE(fs::exists(dir / "second_eye_methods.svg"));
    EXPECT_TRUE(fs::exists(dir / "fig17c_pair.svg"));
}

}  // namespace
