// Runs the parallax binary as a user would and checks exit codes, JSON output, written files and
// one-line errors for bad input.

#include <algorithm>
#include <fstream>
#include <sstream>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli_runner.h"

namespace {

using namespace plx::testing;

fs::path cliDir() { return plx::testing::scratchDir("cli"); }

TEST(Cli, RenderWritesTargetsAndJson) {
    fs::path prefix = cliDir() / "office2";
    RunResult r = runParallax("render office:2 --size 96x64 --frames 2 --threads 2 --out " +
                              prefix.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);  // stdout holds only the JSON document
    for (const char* key : {"triangles", "visible_triangles", "width", "height", "frames",
                            "frame_ms_median", "mtris_per_s"})
        EXPECT_TRUE(doc.contains(key)) << key;
    EXPECT_EQ(doc["width"], 96);
    EXPECT_EQ(doc["frames"], 2);
    EXPECT_GT(doc["visible_triangles"].get<int>(), 10);
    EXPECT_LT(doc["visible_triangles"].get<int>(), doc["triangles"].get<int>());
    for (const char* ext : {".color.png", ".depth.png", ".id.png"})
        EXPECT_TRUE(fs::exists(prefix.string() + ext)) << ext;
}

TEST(Cli, RenderWithExplicitCamera) {
    fs::path prefix = cliDir() / "eye";
    RunResult r = runParallax("render office:1 --size 64x48 --eye 1,1.6,1 --target 4,1,4 "
                              "--shading gouraud --out " + prefix.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["height"], 48);
}

TEST(Cli, InfoReportsScene) {
    RunResult r = runParallax("info office:3 --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    EXPECT_GT(doc["triangles"].get<int>(), 3 * 3000);
}

TEST(Cli, MissingFile) {
    expectOneLineError(runParallax("render /no/such/model.glb --out x"), "/no/such/model.glb");
}

TEST(Cli, CorruptAndTruncatedModels) {
    fs::path dir = cliDir();
    writeFile(dir / "garbage.glb", std::string("glTF\x02\0\0\0\xff\xff\xff\x7f", 12) + "junk");
    expectOneLineError(runParallax("render " + (dir / "garbage.glb").string() + " --out x"),
                       "garbage.glb");
    writeFile(dir / "truncated.ply",
              "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
              "property float y\nproperty float z\nelement face 1\n"
              "property list uchar int vertex_indices\nend_header\n\x01\x02");
    expectOneLineError(runParallax("render " + (dir / "truncated.ply").string() + " --out x"),
                       "truncated.ply");
}

TEST(Cli, AbsurdElementCounts) {
    fs::path path = cliDir() / "huge.ply";
    writeFile(path, "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\n"
                    "property float y\nproperty float z\nelement face 4000000000\n"
                    "property list uchar int vertex_indices\nend_header\n0 0 0\n");
    expectOneLineError(runParallax("render " + path.string() + " --out x"), "huge.ply");
}

TEST(Cli, ModelWithoutTriangles) {
    fs::path path = cliDir() / "lines.obj";
    writeFile(path, "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\n");
    expectOneLineError(runParallax("render " + path.string() + " --out x"), "triangles");
}

TEST(Cli, NonFiniteVertices) {
    fs::path path = cliDir() / "nan.obj";
    writeFile(path, "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n");
    expectOneLineError(runParallax("render " + path.string() + " --out x"), "nan.obj");
}

TEST(Cli, BadSizes) {
    expectOneLineError(runParallax("render office:1 --size 0x0 --out x"), "0x0", 2);
    expectOneLineError(runParallax("render office:1 --size 100000x100000 --out x"),
                       "100000x100000", 2);
    expectOneLineError(runParallax("render office:1 --size banana --out x"), "banana", 2);
}

TEST(Cli, UnknownGeneratorAndBadCounts) {
    expectOneLineError(runParallax("render foo:3 --out x"), "foo");
    expectOneLineError(runParallax("render office:0 --out x"), "office");
    expectOneLineError(runParallax("render office:999999999 --out x"), "office");
    expectOneLineError(runParallax("render showcase:2 --out x"), "takes no count");
}

TEST(Cli, ShowcaseIsABareSceneSpec) {
    RunResult r = runParallax("info showcase --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    EXPECT_EQ(doc["triangles"], 1492);
}

TEST(Cli, BadCameraAndOptions) {
    expectOneLineError(runParallax("render office:1 --eye 1,2 --target 0,0,0 --out x"), "--eye", 2);
    expectOneLineError(runParallax("render office:1 --eye 1e-300,0,0 --out x"),
                       "'1e-300' is beyond a float's range (in '1e-300,0,0')", 2);
    expectOneLineError(runParallax("render office:1 --eye 1,nan,0 --out x"),
                       "'nan' is not a finite number", 2);
    expectOneLineError(runParallax("render office:1 --eye 1,1,1 --target 1,1,1 --size 8x8 --out x"),
                       "coincide", 2);
    expectOneLineError(runParallax("render office:1 --shading phong --out x"), "phong", 2);
    expectOneLineError(runParallax("render office:1 --viewpoint nowhere --out x"), "nowhere", 2);
    expectOneLineError(runParallax("render office:1 --frames 0 --out x"), "frames", 2);
}

// The demo's sections, checked on one `demo --quick` run (each run is tens of seconds under the
// sanitizers).
std::string readText(const fs::path& path) {
    std::ifstream in(path);
    return std::string((std::istreambuf_iterator<char>(in)), {});
}

void expectRasterAndPtm(const nlohmann::json& doc, const std::string& html) {
    EXPECT_TRUE(doc.contains("raster"));
    ASSERT_TRUE(doc.contains("ptm"));
    EXPECT_GT(doc["ptm"]["levels"].get<int>(), 1);
    EXPECT_NE(html.find("<svg"), std::string::npos);
    EXPECT_NE(html.find("office1.id.png"), std::string::npos);
    EXPECT_NE(html.find("ptm_level"), std::string::npos);
}

// The warp section, and the remote section: a real loopback session (experiment_remote.h) at two
// round trips.
void expectWarpAndRemote(const nlohmann::json& doc, const fs::path& dir, const std::string& html) {
    ASSERT_TRUE(doc.contains("warp"));
    EXPECT_FALSE(doc["warp"]["rows"].empty());
    for (const char* file : {"warp_truth.png", "warp_stale.png", "warp_timewarp.png",
                             "warp_warp2.png", "warp_psnr_vs_rtt_office_8.svg"})
        EXPECT_TRUE(fs::exists(dir / file)) << file;
    EXPECT_NE(html.find("warp_warp2.png"), std::string::npos);
    EXPECT_NE(html.find("PSNR against round trip"), std::string::npos);
    ASSERT_TRUE(doc.contains("remote"));
    EXPECT_EQ(doc["remote"]["rows"].size(), 6u);
    for (const char* file : {"remote_truth.png", "remote_warp.png", "remote_video.png",
                             "remote_timewarp.png", "remote_psnr_vs_rtt_office_8.svg"})
        EXPECT_TRUE(fs::exists(dir / file)) << file;
    EXPECT_NE(html.find("remote_video.png"), std::string::npos);
}

// The streaming section: four walks, each under its budget, quality ordered by bandwidth as in
// the paper's Fig. 2, the policy comparison, the plots and a frame written.
void expectStream(const nlohmann::json& doc, const fs::path& dir) {
    ASSERT_TRUE(doc.contains("stream"));
    const auto& walks = doc["stream"]["walks"];
    ASSERT_EQ(walks.size(), 4u);
    for (size_t i = 0; i < walks.size(); ++i) {
        EXPECT_LE(walks[i]["max_resident_bytes"], walks[i]["budget_bytes"]);
        if (i > 0) {
            EXPECT_GE(walks[i]["quality_final"], walks[i - 1]["quality_final"]);
        }
    }
    EXPECT_GT(walks.back()["quality_final"].get<double>(), 0.5);
    EXPECT_EQ(doc["stream"]["policies"].size(), 10u);  // five policies at two budgets
    for (const char* file : {"stream_quality.svg", "stream_resident.svg", "stream_10s.png",
                             "stream_frame_time.svg", "stream_policies.svg"})
        EXPECT_TRUE(fs::exists(dir / file)) << file;
}

TEST(Cli, DemoQuickWritesEverySection) {
    fs::path dir = cliDir() / "demo";
    RunResult r = runParallax("demo --quick --out " + dir.string() + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    auto doc = nlohmann::json::parse(r.out);
    ASSERT_TRUE(fs::exists(dir / "index.html"));
    const std::string html = readText(dir / "index.html");
    expectRasterAndPtm(doc, html);
    expectWarpAndRemote(doc, dir, html);
    expectStream(doc, dir);
}

TEST(Cli, UsageErrorsExitWithTwo) {
    expectOneLineError(runParallax(""), "subcommand", 2);
    expectOneLineError(runParallax("render"), "scene", 2);
    expectOneLineError(runParallax("frobnicate"), "frobnicate", 2);
    expectOneLineError(runParallax("render office:1 --out x --no-such-flag"), "--no-such-flag", 2);
    // CLI11 reads an empty value as zero or as not given: every command's options refuse it
    // (serve --seconds '' served for ever, stream walk '' read /root.json).
    expectOneLineError(runParallax("render office:1 --threads '' --out x"),
                       "--threads: must not be empty", 2);
    expectOneLineError(runParallax("serve office:1 --seconds ''"), "--seconds: must not be empty",
                       2);
    expectOneLineError(runParallax("stream walk '' --tour"), "location: must not be empty", 2);
    expectOneLineError(runParallax("bench warp --rtts ''"), "--rtts: must not be empty", 2);
    EXPECT_EQ(runParallax("--help").exitCode, 0);
    EXPECT_EQ(runParallax("render --help").exitCode, 0);
}

// The names under "Subcommands:" in a --help text, up to the blank line that ends the list.
std::vector<std::string> listedSubcommands(const std::string& help) {
    std::vector<std::string> names;
    std::istringstream lines(help.substr(std::min(help.size(), help.find("Subcommands:"))));
    std::string line;
    std::getline(lines, line);
    while (std::getline(lines, line) && line.size() > 2 && line[2] != ' ') {
        names.push_back(line.substr(2, line.find(' ', 2) - 2));
    }
    return names;
}

// README: every command has --help with an example; the commands are read from the help
// itself, so a new command or group is checked without being named here.
TEST(Cli, EveryCommandsHelpShowsAnExample) {
    std::vector<std::string> commands = listedSubcommands(runParallax("--help").out);
    ASSERT_GE(commands.size(), 10u);
    for (size_t i = 0; i < commands.size(); ++i) {
        RunResult r = runParallax(commands[i] + " --help");
        ASSERT_EQ(r.exitCode, 0) << commands[i];
        EXPECT_NE(r.out.find("\nExample: parallax " + commands[i]), std::string::npos)
            << "parallax " << commands[i] << " --help:\n"
            << r.out;
        for (const std::string& child : listedSubcommands(r.out)) {
            if (std::count(commands[i].begin(), commands[i].end(), ' ') == 0)
                commands.push_back(commands[i] + " " + child);
        }
    }
    EXPECT_GE(commands.size(), 23u);  // 11 commands, 12 under stream, ptm and bench
}

}  // namespace
