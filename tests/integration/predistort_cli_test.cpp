// parallax predistort and bench predistort run as a user would: JSON fields, written files, the
// error bound, and one-line errors for bad input.

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sys/wait.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace {

namespace fs = std::filesystem;

struct RunResult {
    int exitCode = -1;
    std::string out, err;
};

fs::path scratchDir() {
    fs::path dir = fs::path(PLX_TEST_OUTPUT_DIR) / "predistort_cli";
    fs::create_directories(dir);
    return dir;
}

std::string coneDisplay() { return std::string(PLX_SOURCE_DIR) + "/examples/displays/cone_showcase.json"; }

// Runs parallax with the given arguments, bounded by a timeout so a hang fails the test.
RunResult runParallax(const std::string& args) {
    fs::path errFile = scratchDir() / "stderr.txt";
    std::string cmd = "timeout 120 " + std::string(PARALLAX_EXE) + " " + args + " 2>" +
                      errFile.string();
    RunResult r;
    FILE* pipe = popen(cmd.c_str(), "r");
    if (!pipe) return r;
    std::array<char, 4096> buf;
    size_t n;
    while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) r.out.append(buf.data(), n);
    int status = pclose(pipe);
    r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::ifstream e(errFile);
    r.err.assign(std::istreambuf_iterator<char>(e), {});
    return r;
}

void expectOneLineError(const RunResult& r, const std::string& mentions, int code) {
    EXPECT_EQ(r.exitCode, code) << r.err;
    ASSERT_FALSE(r.err.empty());
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err.rfind("parallax: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(mentions), std::string::npos) << "expected '" << mentions << "' in: " << r.err;
}

TEST(PredistortCli, AdaptiveJsonMeetsThresholdAndWritesFiles) {
    fs::path prefix = scratchDir() / "cone";
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
    fs::path u = scratchDir() / "uniform", p = scratchDir() / "pfm";
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

TEST(PredistortCli, BadInputGivesOneLineErrors) {
    std::string out = " --out " + (scratchDir() / "bad").string();
    expectOneLineError(runParallax("predistort " + (scratchDir() / "missing.json").string() +
                                   " --error 1" + out),
                       "missing.json", 1);
    fs::path malformed = scratchDir() / "malformed.json";
    std::ofstream(malformed) << "{\"optics\": {\"type\": \"cone_mirror\"";
    expectOneLineError(runParallax("predistort " + malformed.string() + " --error 1" + out),
                       "malformed.json", 1);
    expectOneLineError(runParallax("predistort " + coneDisplay() + " --error -1" + out),
                       "--error", 2);
    expectOneLineError(runParallax("predistort " + coneDisplay() + " --error 1 --viewer nan,1,2" +
                                   out),
                       "nan", 1);
    expectOneLineError(runParallax("predistort " + coneDisplay() + " --error 1 --method fancy" +
                                   out),
                       "fancy", 2);
    expectOneLineError(runParallax("predistort " + coneDisplay() + " --error 1 --container box" +
                                   out),
                       "box", 1);
    // A viewer inside the mirror cannot see the display through it.
    expectOneLineError(runParallax("predistort " + coneDisplay() + " --error 1 --viewer 0,200,0" +
                                   out),
                       "viewer", 1);
}

TEST(PredistortCli, BenchWritesTableAndPlots) {
    fs::path dir = scratchDir() / "bench";
    RunResult r = runParallax("bench predistort --display " + coneDisplay() +
                              " --thresholds 4,1 --repetitions 1 --out " + dir.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    ASSERT_EQ(doc["rows"].size(), 2u);
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
