// The CLI's own pieces: the embedded example displays against the files they come from, and the
// experiments' typed rows and the JSON and CSV made from them.

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>
#include <tuple>

#include <gtest/gtest.h>

#include <plx/display/display_json.h>
#include <plx/scene/generators.h>

#include "example_displays.h"
#include "experiment_predistort.h"
#include "experiment_remote.h"
#include "experiment_stereo.h"
#include "experiment_warp.h"
#include "hole_classes.h"

namespace plx::cli {
namespace {

namespace fs = std::filesystem;

const fs::path kExamples = fs::path(PLX_SOURCE_DIR) / "examples" / "displays";

std::string readFile(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), {}};
}

size_t lineCount(const std::string& text) {
    return size_t(std::count(text.begin(), text.end(), '\n'));
}

TEST(ExampleDisplays, EmbeddedTextEqualsEachFileOnDisk) {
    std::set<std::string> onDisk;
    for (const auto& entry : fs::directory_iterator(kExamples))
        if (entry.path().extension() == ".json") {
            std::string name = entry.path().stem().string();
            onDisk.insert(name);
            const ExampleDisplay* e = findExampleDisplay(name);
            ASSERT_NE(e, nullptr) << name;
            EXPECT_EQ(std::string(e->json), readFile(entry.path())) << name;
        }
    EXPECT_EQ(onDisk.size(), 4u);
    std::set<std::string> embedded;
    for (const ExampleDisplay& e : exampleDisplays()) embedded.insert(std::string(e.name));
    EXPECT_EQ(embedded, onDisk);
    EXPECT_EQ(findExampleDisplay("no_such_display"), nullptr);
    EXPECT_EQ(exampleDisplayNames(),
              "cone_showcase, cylinder_mirror, cylinder_screen, dome_screen");
}

TEST(ExampleDisplays, ArgumentIsAFileFirstThenAnExampleName) {
    for (const ExampleDisplay& e : exampleDisplays()) {
        auto byName = loadDisplayArgument(std::string(e.name));
        ASSERT_TRUE(byName.isOk()) << e.name << ": " << byName.status().toString();
        auto byFile =
            display::loadDisplayFile((kExamples / (std::string(e.name) + ".json")).string());
        ASSERT_TRUE(byFile.isOk());
        EXPECT_EQ(byName->name, byFile->name);
        EXPECT_EQ(byName->framebufferWidth, byFile->framebufferWidth);
        EXPECT_EQ(byName->defaultViewerMm, byFile->defaultViewerMm);
    }
    // A file of an example's name in the working directory wins over the example.
    fs::path dir = fs::path(PLX_TEST_OUTPUT_DIR) / "parallax_test";
    fs::create_directories(dir);
    std::ofstream(dir / "cone_showcase") << "{";
    fs::path cwd = fs::current_path();
    fs::current_path(dir);
    auto shadowed = loadDisplayArgument("cone_showcase");
    fs::current_path(cwd);
    ASSERT_FALSE(shadowed.isOk());
    EXPECT_NE(shadowed.status().message().find("cone_showcase: "), std::string::npos);
    auto missing = loadDisplayArgument((dir / "missing.json").string());
    ASSERT_FALSE(missing.isOk());
    EXPECT_NE(missing.status().message().find("missing.json"), std::string::npos);
}

TEST(StereoExperiment, RowsHaveSpeedupAndQualityAndSerialise) {
    StereoExperimentConfig config;
    config.rooms = {1, 3};
    config.width = 96;
    config.height = 72;
    config.frames = 1;
    config.threads = 2;
    auto rows = runStereoExperiment(config);
    ASSERT_TRUE(rows.isOk()) << rows.status().toString();
    ASSERT_EQ(rows->size(), 2u);
    EXPECT_EQ((*rows)[0].rooms, 1);
    EXPECT_EQ((*rows)[0].polygons, scene::generateOffice(1)->triangleCount());
    EXPECT_GT((*rows)[1].polygons, (*rows)[0].polygons);
    EXPECT_GT((*rows)[0].visiblePolygons, 0u);
    EXPECT_LE((*rows)[0].visiblePolygons, (*rows)[0].polygons);
    EXPECT_GT((*rows)[0].pairSpeedup, 0.0);
    EXPECT_GT((*rows)[0].secondEyePsnrDb, 20.0);
    for (const StereoExperimentRow& r : *rows) {
        EXPECT_GT(r.reprojectSecondMs, 0.0);
        EXPECT_GT(r.reprojectPairSpeedup, 0.0);
        EXPECT_GE(r.reprojectIdenticalFraction, 0.0);
        EXPECT_LE(r.reprojectIdenticalFraction, 1.0);
        EXPECT_GE(r.reprojectHoleFraction, 0.0);
        EXPECT_LE(r.reprojectHoleFraction, 1.0);
        EXPECT_GT(r.reprojectPsnrDb, 20.0);
    }
    nlohmann::json j = stereoExperimentJson(config, *rows);
    ASSERT_EQ(j["rows"].size(), 2u);
    EXPECT_EQ(j["width"], 96);
    EXPECT_EQ(j["rows"][1]["rooms"], 3);
    EXPECT_EQ(j["rows"][0]["polygons"].get<size_t>(), (*rows)[0].polygons);
    // JSON has no infinity: identical eyes read 99 dB.
    std::vector<StereoExperimentRow> identical = {(*rows)[0]};
    identical[0].secondEyePsnrDb = std::numeric_limits<double>::infinity();
    EXPECT_EQ(stereoExperimentJson(config, identical)["rows"][0]["second_eye_psnr_db"], 99.0);
    std::string csv = stereoExperimentCsv(config, *rows);
    EXPECT_EQ(lineCount(csv), 3u);
    EXPECT_EQ(csv.rfind("rooms,polygons,visible_polygons,", 0), 0u);
    // Skipped measurements: null in JSON and empty in CSV, not 0 (0 dB, a 0x speedup), with
    // every line as many columns as the header.
    StereoExperimentConfig skipped = config;
    skipped.conservative = skipped.reproject = false;
    const nlohmann::json nulls = stereoExperimentJson(skipped, *rows)["rows"][0];
    for (const char* key : {"conservative_psnr_db", "reproject_pair_speedup", "fill_ms"})
        EXPECT_TRUE(nulls[key].is_null()) << key;
    EXPECT_EQ(nulls["pair_speedup"].get<double>(), (*rows)[0].pairSpeedup);
    const std::string blanks = stereoExperimentCsv(skipped, *rows);
    EXPECT_EQ(lineCount(blanks), 3u);
    const auto columns = [](std::string_view line) {
        return std::count(line.begin(), line.end(), ',');
    };
    const std::string_view header(blanks.data(), blanks.find('\n'));
    const std::string_view first(blanks.data() + header.size() + 1,
                                 blanks.find('\n', header.size() + 1) - header.size() - 1);
    EXPECT_EQ(columns(first), columns(header));
    EXPECT_NE(first.find(",,,,,,,,,,,,"), std::string_view::npos) << first;
    EXPECT_EQ(j["rows"][0]["reproject_second_ms"].get<double>(), (*rows)[0].reprojectSecondMs);
    EXPECT_EQ(stereoPlots(*rows).size(), 6u);
    // Markdown: header, rule, one line a row; the paper's four columns.
    EXPECT_EQ(lineCount(stereoMethodsMarkdown(*rows)), 4u);
    std::string paper = reprojectPaperTableMarkdown(*rows);
    EXPECT_EQ(lineCount(paper), 4u);
    EXPECT_EQ(paper.rfind("| polygons | left", 0), 0u);
    EXPECT_NE(paper.find("| 3,632 |"), std::string::npos);
}

TEST(StereoExperiment, WithoutReprojectHasNoReprojectPlot) {
    StereoExperimentConfig config;
    config.rooms = {1};
    config.width = 48;
    config.height = 32;
    config.frames = 1;
    config.threads = 2;
    config.conservative = false;
    config.reproject = false;
    auto rows = runStereoExperiment(config);
    ASSERT_TRUE(rows.isOk()) << rows.status().toString();
    EXPECT_EQ((*rows)[0].reprojectSecondMs, 0.0);
    EXPECT_GT((*rows)[0].pairSpeedup, 0.0);
    EXPECT_EQ(stereoPlots(*rows).size(), 6u);
}

TEST(HoleClasses, ImageColoursEachClassAndDimsTheRest) {
    Image<Rgba8> eye(5, 1, Rgba8{90, 120, 150, 255});
    Image<uint8_t> classes(5, 1);
    classes.at(1, 0) = uint8_t(stereo::PixelSource::kExpansion);
    classes.at(2, 0) = uint8_t(stereo::PixelSource::kDisocclusion);
    classes.at(3, 0) = uint8_t(stereo::PixelSource::kDisocclusionEmpty);
    classes.at(4, 0) = 200;  // not a PixelSource: shown as reprojected
    Image<Rgba8> out = holeClassImage(eye, classes);
    EXPECT_EQ(out.at(0, 0), (Rgba8{30, 40, 50, 255}));
    EXPECT_EQ(out.at(4, 0), (Rgba8{30, 40, 50, 255}));
    std::set<std::tuple<int, int, int>> holeColours;
    for (int x = 1; x <= 3; ++x)
        holeColours.insert({out.at(x, 0).r, out.at(x, 0).g, out.at(x, 0).b});
    EXPECT_EQ(holeColours.size(), 3u);  // three distinct colours
}

TEST(HoleClasses, TrianglesShownAreTheDistinctIdsLessOne) {
    Image<uint32_t> ids(4, 2, 0u);
    ids.at(0, 0) = 7;
    ids.at(1, 0) = 3;
    ids.at(2, 1) = 7;
    EXPECT_EQ(trianglesShown(ids), (std::vector<uint32_t>{2, 6}));
    EXPECT_TRUE(trianglesShown(Image<uint32_t>(3, 3, 0u)).empty());
}

TEST(StereoExperiment, RejectsAnEmptyConfigAndBlindEyes) {
    StereoExperimentConfig config;
    config.rooms.clear();
    EXPECT_FALSE(runStereoExperiment(config).isOk());
    // Eyes that see nothing gave blank images, 99 dB and a 1.8x speedup as a result.
    config.rooms = {1};
    config.width = 32, config.height = 24;
    config.frames = 1;
    config.conservative = config.reproject = false;
    config.rig.separation = 2147483648.0f;
    auto blind = runStereoExperiment(config);
    ASSERT_FALSE(blind.isOk());
    EXPECT_NE(blind.status().message().find("office:1: the first eye sees none of the scene"),
              std::string::npos)
        << blind.status().message();
}

TEST(PredistortExperiment, RowsMeetTheThresholdAndSerialise) {
    display::Display d = exampleDisplay("cone_showcase");
    d.framebufferWidth = d.framebufferHeight = 256;
    PredistortExperimentConfig config;
    config.thresholdsMm = {4.0, 1.0};
    config.gridLevel = 7;
    config.repetitions = 1;
    config.pass1Size = 128;
    config.threads = 2;
    auto content = display::fitSceneToContent(*scene::generateShowcase(), d);
    auto e = runPredistortExperiment(d, d.defaultViewerMm, content, config);
    ASSERT_TRUE(e.isOk()) << e.status().toString();
    ASSERT_EQ(e->rows.size(), 2u);
    EXPECT_EQ(e->rendererThreads, 2);
    for (const PredistortExperimentRow& r : e->rows) {
        EXPECT_LE(r.uniform.maxMeasuredErrorMm, r.errorMm);
        EXPECT_LE(r.adaptiveContainer.maxMeasuredErrorMm, r.errorMm);
        // The container only removes patches the exhibit cannot be seen through.
        EXPECT_LE(r.adaptiveContainer.triangles, r.adaptiveFull.triangles);
        EXPECT_GT(r.adaptiveContainer.triangles, 0u);
        EXPECT_GT(r.adaptiveFull.speedup, 0.0);
    }
    // A finer threshold needs at least as fine a uniform grid.
    EXPECT_GE(e->rows[1].uniform.level, e->rows[0].uniform.level);
    nlohmann::json j = predistortExperimentJson(*e);
    EXPECT_EQ(j["container"], "hull");
    EXPECT_EQ(j["grid_level"], 7);
    ASSERT_EQ(j["rows"].size(), 2u);
    EXPECT_EQ(j["rows"][1]["error_mm"], 1.0);
    EXPECT_EQ(j["rows"][0]["adaptive_container"]["triangles"].get<size_t>(),
              e->rows[0].adaptiveContainer.triangles);
    EXPECT_EQ(j["rows"][0]["uniform"]["level"], e->rows[0].uniform.level);
    std::string csv = predistortExperimentCsv(*e);
    EXPECT_EQ(lineCount(csv), 3u);
    EXPECT_EQ(csv.rfind("error_mm,uniform_level,", 0), 0u);
    EXPECT_EQ(predistortPlots(*e).size(), 3u);
}

TEST(PredistortExperiment, RejectsBadThresholds) {
    display::Display d = exampleDisplay("cone_showcase");
    auto content = display::fitSceneToContent(*scene::generateShowcase(), d);
    PredistortExperimentConfig config;
    config.thresholdsMm = {1.0, -2.0};
    auto e = runPredistortExperiment(d, d.defaultViewerMm, content, config);
    ASSERT_FALSE(e.isOk());
    EXPECT_NE(e.status().message().find("error threshold -2 mm"), std::string::npos)
        << e.status().message();
}

WarpExperimentConfig tinyWarpConfig() {
    WarpExperimentConfig c;
    c.scenes = {"office:1"};
    c.rttsMs = {0, 200};
    c.durationS = 0.05;
    c.width = 64;
    c.height = 48;
    c.threads = 2;
    c.throughputSizes = {{64, 48}};
    c.throughputThreads = {1};
    c.throughputScene = "office:1";
    c.sizeScenes = {"office:2"};
    c.throughputFrames = 1;
    return c;
}

TEST(WarpExperiment, RowsForEveryMethodAndRttAndSerialise) {
    WarpExperimentConfig c = tinyWarpConfig();
    c.modelPath = "/no/such/model.glb";
    auto e = runWarpExperiment(c);
    ASSERT_TRUE(e.isOk()) << e.status().toString();
    ASSERT_EQ(e->latency.size(), std::size(kLatencyMethods) * c.rttsMs.size());
    for (const LatencyRow& r : e->latency) {
        EXPECT_EQ(r.scene, "office:1");
        EXPECT_EQ(r.frames, 3);
        EXPECT_GT(r.psnrDbMedian, 5.0);
        EXPECT_LE(r.psnrDbMedian, 99.0);
        EXPECT_GE(r.holeFractionMedian, 0.0);
        EXPECT_LE(r.holeFractionMedian, 1.0);
        // The stale frame is shown as rendered: no warp, no time; every other method has one.
        EXPECT_EQ(r.warpMsMedian.has_value(), r.method != LatencyMethod::kStale);
    }
    // The model is missing: a note, no rows.
    ASSERT_EQ(e->notes.size(), 1u);
    EXPECT_NE(e->notes[0].find("/no/such/model.glb"), std::string::npos);
    // Two sets cover at least what the newest alone covers.
    auto row = [&](LatencyMethod m, double rtt) {
        for (const LatencyRow& r : e->latency)
            if (r.method == m && r.rttMs == rtt) return r;
        return LatencyRow{};
    };
    EXPECT_LE(row(LatencyMethod::kWarp2, 200).holeFractionMedian,
              row(LatencyMethod::kWarp1, 200).holeFractionMedian);
    ASSERT_EQ(e->throughput.size(), 2u);
    EXPECT_EQ(e->throughput[1].scene, "office:2");
    EXPECT_GT(e->throughput[0].warpedPixels, 0);
    EXPECT_GE(e->throughput[0].sourcePixels, e->throughput[0].warpedPixels);
    nlohmann::json j = warpExperimentJson(*e);
    EXPECT_EQ(j["rows"].size(), e->latency.size());
    EXPECT_EQ(j["rows"][0]["method"], "stale");
    EXPECT_EQ(j["throughput"].size(), 2u);
    EXPECT_EQ(lineCount(latencyCsv(*e)), e->latency.size() + 1);
    EXPECT_EQ(lineCount(throughputCsv(*e)), 3u);
    EXPECT_EQ(warpPlots(*e).size(), 3u);  // PSNR and holes for office:1, throughput
}

TEST(WarpExperiment, IsDeterministicApartFromTimes) {
    WarpExperimentConfig c = tinyWarpConfig();
    c.throughputSizes.clear();
    c.sizeScenes.clear();
    auto a = runWarpExperiment(c), b = runWarpExperiment(c);
    ASSERT_TRUE(a.isOk() && b.isOk());
    ASSERT_EQ(a->latency.size(), b->latency.size());
    for (size_t i = 0; i < a->latency.size(); ++i) {
        EXPECT_EQ(a->latency[i].psnrDbMedian, b->latency[i].psnrDbMedian) << i;
        EXPECT_EQ(a->latency[i].holeFractionMedian, b->latency[i].holeFractionMedian) << i;
    }
}

TEST(WarpExperiment, ExampleKeepsEveryMethodsImage) {
    auto ex = latencyExample("office:1", tinyWarpConfig(), 100.0, 1);
    ASSERT_TRUE(ex.isOk()) << ex.status().toString();
    EXPECT_EQ(ex->truth.width(), 64);
    ASSERT_EQ(ex->images.size(), std::size(kLatencyMethods));
    for (size_t i = 0; i < ex->images.size(); ++i) {
        EXPECT_EQ(ex->images[i].method, kLatencyMethods[i]);
        EXPECT_EQ(ex->images[i].image.width(), 64);
        EXPECT_GT(ex->images[i].psnrDb, 5.0);
    }
}

TEST(WarpExperiment, RejectsBadConfigs) {
    WarpExperimentConfig c = tinyWarpConfig();
    c.rttsMs.clear();
    EXPECT_FALSE(runWarpExperiment(c).isOk());
    c = tinyWarpConfig();
    c.rttsMs = {-1.0};
    EXPECT_FALSE(runWarpExperiment(c).isOk());
    c = tinyWarpConfig();
    c.refreshMs = 0.0;
    EXPECT_FALSE(runWarpExperiment(c).isOk());
    c = tinyWarpConfig();
    c.width = 0;
    EXPECT_FALSE(runWarpExperiment(c).isOk());
    c = tinyWarpConfig();
    c.scenes = {"office:0"};
    EXPECT_FALSE(runWarpExperiment(c).isOk());
}

TEST(WarpExperiment, ReferenceFacesMatchTheDisplayDensity) {
    auto scene = scene::generateOffice(1);
    scene::Viewpoint vp = scene::defaultViewpoint(*scene);
    vp.fovYDegrees = 60.0f;
    auto cam = scene::cameraAt(*scene, vp, 320, 240);
    ASSERT_TRUE(cam.isOk());
    // The paper's 416-pixel faces for 320x240 at 60 degrees.
    EXPECT_EQ(referenceOptionsFor(*scene, *cam, warp::ReferenceLayout::kCube4).faceSize, 416);
    warp::ReferenceSetOptions wide =
        referenceOptionsFor(*scene, *cam, warp::ReferenceLayout::kWide);
    EXPECT_GT(wide.wideFovDegrees, 60.0f);
    EXPECT_GT(wide.faceSize, 240);
}

TEST(RemoteExperiment, FacesStayWithinWhatTheProtocolCarries) {
    // 2560 rows at 60 degrees have the density of 4434-pixel faces: the server renders 4096.
    auto large = displayOfSize(2560, 2560);
    ASSERT_TRUE(large.isOk());
    EXPECT_EQ(referenceDensityFor(*large, warp::ReferenceLayout::kCube4).faceSize, 4434);
    EXPECT_EQ(remoteReferenceFor(*large, warp::ReferenceLayout::kCube4).faceSize,
              remote::kMaxFaceSize);
    auto tiny = displayOfSize(4, 3);
    ASSERT_TRUE(tiny.isOk());
    EXPECT_EQ(remoteReferenceFor(*tiny, warp::ReferenceLayout::kCube4).faceSize,
              remote::kMinFaceSize);
    // A 20:1 wide view of 100 rows has the density of 206-pixel faces, 4120 wide: the server
    // renders 204 (4080 wide), within the 4096 columns clients decode.
    auto strip = displayOfSize(2000, 100);
    ASSERT_TRUE(strip.isOk());
    EXPECT_EQ(referenceDensityFor(*strip, warp::ReferenceLayout::kWide).faceSize, 206);
    EXPECT_EQ(remoteReferenceFor(*strip, warp::ReferenceLayout::kWide).faceSize, 204);
    // Four faces of 4096 pixels: what the memory estimate counts.
    auto pixels = referencePixels(remoteReferenceFor(*large, warp::ReferenceLayout::kCube4));
    ASSERT_TRUE(pixels.isOk());
    EXPECT_EQ(*pixels, 4 * int64_t(4096) * 4096);
}

}  // namespace
}  // namespace plx::cli
