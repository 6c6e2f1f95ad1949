// parallax predistort and bench predistort run as a user would: JSON fields, written files, the
// error bound, and one-line errors for bad input.

#include <nlohmann/json.hpp>

#include "cli_runner.h"

namespace {

using namespace plx::testing;

fs::path predistortDir() { return plx::testing::scratchDir("predistort_cli"); }

std::string coneDisplay() { return std::string(PLX_SOURCE_DIR) + "/examples/displays/cone_showcase.json"; }

TEST(PredistortCli, AdaptiveJsonMeetsThresholdAndWritesFiles) {
    fs::path prefix = predistortDir() / "cone";
    RunResult r = runParallax("predistort " + coneDisplay() + " --error 1 --out " +
                              prefix.string() + " --json --pass1-size 128 --grid-level 7");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    for (const char* key : {"method", "error_mm", "max_measured_error_mm", "vertices",
                            "triangles", "patches", "generate_ms", "render_ms"})
        EXPECT_TRUE(doc.contains(key)) << key;
    EXPECT_EQ(doc["method"], "adaptive");
    EXPECT_LE(doc["max_measured_error_mm"].get<double>(), 1.0);
    EXPECT_GT(doc["triangles"].get<int>(), 0);
    for (const char* suffix : {"_mesh.txt", "_overlay.png", "_frame.png"})
        EXPECT_GT(fs::file_size(prefix.string() + suffix), 0u) << suffix;
}

TEST(PredistortCli, UniformObjAndAdaptivePfm) {
    fs::path u = predistortDir() / "uniform", p = predistortDir() / "pfm";
    RunResult r = runParallax("predistort " + coneDisplay() + " --error 2 --method uniform " +
                              "--format obj --pass1-size 128 --out " + u.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["method"], "uniform");
    EXPECT_LE(doc["max_measured_error_mm"].get<double>(), 2.0);
    std::ifstream obj(u.string() + "_mesh.obj");
    std::string first;
    std::getline(obj, first);
    EXPECT_FALSE(first.empty());
    r = runParallax("predistort " + coneDisplay() + " --error 2 --container none --format pfm " +
                    "--viewer 0,500,700 --pass1-size 128 --grid-level 7 --out " + p.string());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    std::ifstream pfm(p.string() + "_warp.pfm", std::ios::binary);
    std::string magic(2, '\0');
    pfm.read(magic.data(), 2);
    EXPECT_EQ(magic, "PF");
}

// An example display's name, with no file of that name, gives the embedded example: the same
// mesh as the file; "showcase" is the built-in exhibit as a scene spec.
TEST(PredistortCli, ExampleDisplayByNameEqualsItsFile) {
    std::string args = " --error 2 --pass1-size 64 --grid-level 6 --json --out ";
    RunResult byFile = runParallax("predistort " + std::string(PLX_SOURCE_DIR) +
                                   "/examples/displays/cylinder_mirror.json" + args +
                                   (predistortDir() / "file").string());
    RunResult byName = runParallax("predistort cylinder_mirror --scene showcase" + args +
                                   (predistortDir() / "name").string());
    ASSERT_EQ(byFile.exitCode, 0) << byFile.err;
    ASSERT_EQ(byName.exitCode, 0) << byName.err;
    auto a = nlohmann::json::parse(byFile.out), b = nlohmann::json::parse(byName.out);
    for (const char* key : {"display", "vertices", "triangles", "max_measured_error_mm"})
        EXPECT_EQ(a[key], b[key]) << key;
    EXPECT_EQ(a["scene"], "built-in exhibit");
    EXPECT_EQ(b["scene"], "showcase");
    expectOneLineError(runParallax("predistort no_such_display --error 1 --out " +
                                   (predistortDir() / "none").string()),
                       "no_such_display", 1);
}

TEST(PredistortCli, BadInputGivesOneLineErrors) {
    std::string out = " --out " + (predistortDir() / "bad").string();
    expectOneLineError(runParallax("predistort " + (predistortDir() / "missing.json").string() +
                                   " --error 1" + out),
                       "missing.json", 1);
    fs::path malformed = predistortDir() / "malformed.json";
    std::ofstream(malformed) << "{\"optics\": {\"type\": \"cone_mirror\"";
    expectOneLineError(runParallax("predistort " + malformed.string() + " --error 1" + out),
                       "malformed.json", 1);
    expectOneLineError(runParallax("predistort " + coneDisplay() + " --error -1" + out),
                       "--error", 2);
    expectOneLineError(
        runParallax("predistort " + coneDisplay() + " --error 1 --viewer nan,1,2" + out), "nan", 2);
    expectOneLineError(runParallax("predistort " + coneDisplay() + " --error 1 --method fancy" +
                                   out),
                       "fancy", 2);
    expectOneLineError(
        runParallax("predistort " + coneDisplay() + " --error 1 --container box" + out), "box", 2);
    expectOneLineError(
        runParallax("predistort " + coneDisplay() + " --error 1 --grid-level 12" + out),
        "--grid-level", 2);
    expectOneLineError(runParallax("bench predistort --container box --thresholds 8" + out), "box",
                       2);
    // A viewer inside the mirror cannot see the display through it.
    expectOneLineError(runParallax("predistort " + coneDisplay() + " --error 1 --viewer 0,200,0" +
                                   out),
                       "viewer", 1);
}

TEST(PredistortCli, BenchWritesTableAndPlots) {
    fs::path dir = predistortDir() / "bench";
    RunResult r = runParallax("bench predistort --display " + coneDisplay() +
                              " --thresholds 4,1 --repetitions 1 --out " + dir.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    ASSERT_EQ(doc["rows"].size(), 2u);
    EXPECT_EQ(doc["container"], "hull");  // the default container of grid B
    for (const auto& row : doc["rows"]) {
        double thr = row["error_mm"].get<double>();
        EXPECT_LE(row["adaptive_container"]["max_measured_error_mm"].get<double>(), thr);
        EXPECT_LE(row["uniform"]["max_measured_error_mm"].get<double>(), thr);
    }
    for (const char* f : {"table1.csv", "table1.json", "fig8_vertices.svg", "fig9_triangles.svg",
                          "fig10_time.svg"})
        EXPECT_GT(fs::file_size(dir / f), 0u) << f;
}

}  // namespace
