// plx_raster_vs_llvmpipe: Parallax's software rasterizer against Mesa llvmpipe (OpenGL 4.5 core
// through EGL, no display) on the same scenes, cameras and image size, with equivalent work:
// depth test, a flat-shaded colour target and a 32-bit polygon-ID target (gl_PrimitiveID on the
// GL side), the same thread count for both (LP_NUM_THREADS for llvmpipe).
//
// Per scene: one untimed frame of each renderer checks equivalence (fraction of pixels whose IDs
// agree), then warm-up and timed frames alternate between the two renderers frame by frame, the
// first renderer alternating too, so that load from other processes falls on both alike. GL frames
// are clear + draw + glFinish without readback; Parallax renders into caller-owned targets.
// Prints a table (or --json) with median milliseconds, Mtri/s of each and their ratio.
//
//   plx_raster_vs_llvmpipe                          # default scene list, 1280x720, 2 threads
//   plx_raster_vs_llvmpipe --scene office:16 --scene model.glb --no-defaults --csv out/peer.csv
//   plx_raster_vs_llvmpipe --scene subdiv2:model.glb  # the model midpoint-subdivided twice

#include <charconv>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <plx/core/cpu.h>
#include <plx/gl/gl_renderer.h>
#include <plx/raster/raster.h>
#include <plx/scene/import.h>
#include <plx/scene/subdivide.h>

namespace {

using namespace plx;

constexpr const char* kSubdividePrefix = "subdiv";
constexpr int kMaxFrames = 10000;

struct Options {
    std::vector<std::string> scenes;
    bool noDefaults = false;
    std::string size = "1280x720";
    int threads = 2;
    int tileSize = raster::RendererConfig{}.tileSize;
    int warmup = 3;
    int frames = 15;
    bool json = false;
    std::string csvPath;
    std::string only;  // "parallax" or "llvmpipe": time that renderer alone (for profilers)
};

// A scene to measure: the spec as given, the loadable spec, the subdivision levels it asks for
// and the viewpoint it names ("SPEC@NAME"; empty: the scene's default viewpoint).
struct SceneSpec {
    std::string spec;
    std::string source;
    int levels = 0;
    std::string viewpoint;
};

struct Row {
    std::string scene;  // label naming any subdivision, e.g. "DamagedHelmet.glb subdivided x16"
    std::string spec;
    uint64_t triangles = 0;
    size_t visible = 0;        // distinct IDs in Parallax's ID target
    double idMatchAll = 0.0;   // fraction of all pixels with equal IDs
    double idMatchDrawn = 0.0; // same, over pixels where either renderer drew a triangle
    double parallaxMs = 0.0, glMs = 0.0;  // medians
    double parallaxMtri = 0.0, glMtri = 0.0;
    double ratio = 0.0;  // Parallax throughput / llvmpipe throughput
};

std::string helmetPath() {
    return std::string(PLX_SHARED_DATA_DIR) + "/models/DamagedHelmet/DamagedHelmet.glb";
}

std::vector<std::string> defaultScenes() {
    std::string helmet = helmetPath();
    return {"office:64",        "office:64@vista",     "office:280",
            "office:280@vista", helmet,                "subdiv2:" + helmet,
            "subdiv3:" + helmet};
}

// "subdivN:SPEC" asks for SPEC midpoint-subdivided N times; anything else is loaded as is.
Result<SceneSpec> parseSceneSpec(const std::string& spec) {
    SceneSpec out{spec, spec, 0, ""};
    size_t at = spec.rfind('@');
    if (at != std::string::npos && spec.find('/', at) == std::string::npos) {
        out.viewpoint = spec.substr(at + 1);
        out.source = spec.substr(0, at);
        if (out.viewpoint.empty() || out.source.empty())
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("scene '{}': expected SPEC@VIEWPOINT", spec));
    }
    const std::string whole = out.source;
    size_t prefix = std::string(kSubdividePrefix).size();
    size_t colon = whole.find(':');
    if (whole.rfind(kSubdividePrefix, 0) != 0 || colon == std::string::npos) return out;
    int levels = -1;
    auto [end, ec] = std::from_chars(whole.data() + prefix, whole.data() + colon, levels);
    if (ec != std::errc() || end != whole.data() + colon || levels < 0 ||
        levels > scene::kMaxSubdivisionLevels || colon + 1 == whole.size()) {
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("scene '{}': expected subdivN:SPEC with N in [0, {}]",
                                       spec, scene::kMaxSubdivisionLevels));
    }
    out.source = whole.substr(colon + 1);
    out.levels = levels;
    return out;
}

std::string sceneLabel(const SceneSpec& spec) {
    std::string name = scene::isGeneratorSpec(spec.source)
                           ? spec.source
                           : std::filesystem::path(spec.source).filename().string();
    if (!spec.viewpoint.empty()) name += fmt::format(" ({} view)", spec.viewpoint);
    if (spec.levels == 0) return name;
    return fmt::format("{} subdivided x{}", name, 1u << (2 * spec.levels));
}

Result<scene::Scene> loadSpec(const SceneSpec& spec) {
    scene::ImportOptions importOptions;
    importOptions.loadTextures = false;  // flat shading reads base colours only
    auto loaded = scene::loadScene(spec.source, importOptions);
    if (!loaded || spec.levels == 0) return loaded;
    return scene::subdivideMidpoint(*loaded, spec.levels);
}

// The named viewpoint, else the scene's default one; one Camera serves both renderers.
Result<Camera> sceneCamera(const scene::Scene& scene, const std::string& viewpoint, int width,
                           int height) {
    auto v = scene::findViewpoint(scene, viewpoint);
    if (!v) return v.status();
    return scene::cameraAt(scene, *v, width, height);
}

// The two renderers and Parallax's caller-owned targets, set up once for every scene.
struct Peers {
    std::unique_ptr<raster::Renderer> parallax;
    std::unique_ptr<gl::GlRenderer> llvmpipe;
    raster::FrameBuffers buffers;
    raster::RenderOptions options;  // flat shading, clear colour, light as GlConfig's defaults
};

Result<Peers> createPeers(const Options& options) {
    Peers peers;
    auto parallax = raster::Renderer::create({options.threads, options.tileSize});
    if (!parallax) return parallax.status();
    peers.parallax = std::move(parallax).value();
    gl::GlConfig config;
    config.threads = options.threads;
    config.requireLlvmpipe = true;
    auto llvmpipe = gl::GlRenderer::create(config);
    if (!llvmpipe) return llvmpipe.status();
    peers.llvmpipe = std::move(llvmpipe).value();
    peers.options.shading = raster::Shading::kFlat;
    peers.options.lightDir = config.lightDir;
    peers.options.ambient = config.ambient;
    peers.options.clearColor = config.clearColor;
    return peers;
}

// Renders one frame of each and compares the ID targets pixel by pixel.
Status compareIds(Peers& peers, const scene::Scene& scene, const Camera& camera, Row* row) {
    peers.parallax->render(scene, camera, peers.options, peers.buffers.targets());
    Image<uint32_t> glIds;
    auto stats = peers.llvmpipe->render(camera, {nullptr, &glIds, nullptr});
    if (!stats) return stats.status();
    const Image<uint32_t>& ids = peers.buffers.id;
    size_t equal = 0, drawn = 0, drawnEqual = 0;
    for (int y = 0; y < ids.height(); ++y) {
        for (int x = 0; x < ids.width(); ++x) {
            uint32_t a = ids.at(x, y), b = glIds.at(x, y);
            bool same = a == b;
            equal += same;
            if (a != 0 || b != 0) {
                ++drawn;
                drawnEqual += same;
            }
        }
    }
    row->idMatchAll = double(equal) / double(ids.pixelCount());
    row->idMatchDrawn = drawn == 0 ? 1.0 : double(drawnEqual) / double(drawn);
    row->visible = raster::countDistinctIds(ids);
    return Status::ok();
}

// Alternates the renderers frame by frame (and which goes first) and keeps the timed medians.
Status timeScene(Peers& peers, const scene::Scene& scene, const Camera& camera,
                 const Options& options, Row* row) {
    std::vector<double> parallaxMs, glMs;
    for (int frame = 0; frame < options.warmup + options.frames; ++frame) {
        double parallaxTime = 0.0, glTime = 0.0;
        for (int turn = 0; turn < 2; ++turn) {
            bool parallaxTurn = (turn + frame) % 2 == 0;
            if (options.only == (parallaxTurn ? "llvmpipe" : "parallax")) continue;
            if (parallaxTurn) {
                Stopwatch watch;
                peers.parallax->render(scene, camera, peers.options, peers.buffers.targets());
                parallaxTime = watch.elapsedMs();
            } else {
                auto stats = peers.llvmpipe->render(camera);
                if (!stats) return stats.status();
                glTime = stats->renderMs;
            }
        }
        if (frame < options.warmup) continue;
        parallaxMs.push_back(parallaxTime);
        glMs.push_back(glTime);
    }
    row->parallaxMs = median(parallaxMs);
    row->glMs = median(glMs);
    // Rows timing one renderer alone (--only) leave the other's figures and the ratio at 0.
    auto mtri = [&](double ms) { return ms > 0.0 ? double(row->triangles) / (ms * 1e3) : 0.0; };
    row->parallaxMtri = mtri(row->parallaxMs);
    row->glMtri = mtri(row->glMs);
    row->ratio = row->glMtri > 0.0 ? row->parallaxMtri / row->glMtri : 0.0;
    return Status::ok();
}

Result<Row> measureScene(Peers& peers, const SceneSpec& spec, const Options& options, int width,
                         int height) {
    auto scene = loadSpec(spec);
    if (!scene) return scene.status();
    auto camera = sceneCamera(*scene, spec.viewpoint, width, height);
    if (!camera) return camera.status();
    PLX_RETURN_IF_ERROR(peers.llvmpipe->upload(*scene));
    peers.buffers.resize(width, height);
    Row row;
    row.scene = sceneLabel(spec);
    row.spec = spec.spec;
    row.triangles = scene->triangleCount();
    PLX_RETURN_IF_ERROR(compareIds(peers, *scene, *camera, &row));
    PLX_RETURN_IF_ERROR(timeScene(peers, *scene, *camera, options, &row));
    return row;
}

nlohmann::json rowJson(const Row& row) {
    return {{"scene", row.scene},
            {"spec", row.spec},
            {"triangles", row.triangles},
            {"visible_triangles", row.visible},
            {"id_match_all", row.idMatchAll},
            {"id_match_drawn", row.idMatchDrawn},
            {"parallax_median_ms", row.parallaxMs},
            {"llvmpipe_median_ms", row.glMs},
            {"parallax_mtri_per_s", row.parallaxMtri},
            {"llvmpipe_mtri_per_s", row.glMtri},
            {"ratio", row.ratio}};
}

// Writes the rows to `out`, opened by the caller before measuring so that a bad path fails early.
Status writeCsv(std::ofstream& out, const std::string& path, const std::vector<Row>& rows) {
    out << "scene,spec,triangles,visible_triangles,id_match_all,id_match_drawn,"
           "parallax_median_ms,llvmpipe_median_ms,parallax_mtri_per_s,llvmpipe_mtri_per_s,"
           "ratio\n";
    for (const Row& r : rows) {
        out << fmt::format("\"{}\",\"{}\",{},{},{:.5f},{:.5f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f}\n",
                           r.scene, r.spec, r.triangles, r.visible, r.idMatchAll, r.idMatchDrawn,
                           r.parallaxMs, r.glMs, r.parallaxMtri, r.glMtri, r.ratio);
    }
    out.flush();
    if (!out) return errorStatus(ErrorCode::kIoError, fmt::format("error writing '{}'", path));
    return Status::ok();
}

// A figure, or "-" for a renderer that --only left out.
std::string cell(double value, const char* suffix = "") {
    return value > 0.0 ? fmt::format("{:.2f}{}", value, suffix) : std::string("-");
}

void printTable(const std::vector<Row>& rows) {
    fmt::print("{:<36} {:>9} {:>8} {:>8} {:>9} {:>9} {:>9} {:>9} {:>7}\n", "scene", "triangles",
               "visible", "ID match", "plx ms", "gl ms", "plx Mt/s", "gl Mt/s", "ratio");
    for (const Row& r : rows) {
        fmt::print("{:<36} {:>9} {:>8} {:>7.2f}% {:>9} {:>9} {:>9} {:>9} {:>7}\n", r.scene,
                   r.triangles, r.visible, 100.0 * r.idMatchDrawn, cell(r.parallaxMs),
                   cell(r.glMs), cell(r.parallaxMtri), cell(r.glMtri), cell(r.ratio, "x"));
    }
}

Status checkOptions(const Options& options) {
    if (options.threads < 1 || options.threads > 256) {
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--threads {} outside [1, 256]", options.threads));
    }
    if (options.frames < 1 || options.frames > kMaxFrames || options.warmup < 0 ||
        options.warmup > kMaxFrames) {
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--frames must be in [1, {0}] and --warmup in [0, {0}]",
                                       kMaxFrames));
    }
    return Status::ok();
}

Status run(const Options& options) {
    PLX_RETURN_IF_ERROR(checkOptions(options));
    auto size = parseImageSize(options.size);
    if (!size) return errorStatus(size.status().code(), "--size: " + size.status().message());
    const int width = size->x, height = size->y;
    std::vector<std::string> specs = options.noDefaults ? std::vector<std::string>{}
                                                        : defaultScenes();
    specs.insert(specs.end(), options.scenes.begin(), options.scenes.end());
    if (specs.empty()) return errorStatus(ErrorCode::kInvalidArgument, "no scene to measure");
    std::vector<SceneSpec> parsed;
    for (const std::string& spec : specs) {
        auto p = parseSceneSpec(spec);
        if (!p) return p.status();
        parsed.push_back(*p);
    }
    std::ofstream csv;
    if (!options.csvPath.empty()) {
        csv.open(options.csvPath);
        if (!csv) {
            return errorStatus(ErrorCode::kIoError,
                               fmt::format("cannot write '{}'", options.csvPath));
        }
    }
    auto peers = createPeers(options);
    if (!peers) return peers.status();
    if (!options.json) {
        fmt::print("Parallax raster::Renderer ({} threads, {}-pixel tiles, {} path) vs {} ({}), "
                   "LP_NUM_THREADS={}, {}x{}, flat shading, {} warm-up + {} timed frames, "
                   "alternating\n",
                   peers->parallax->threadCount(), options.tileSize, isaName(activeIsa()),
                   peers->llvmpipe->rendererName(),
                   peers->llvmpipe->versionString(), peers->llvmpipe->threads(), width, height,
                   options.warmup, options.frames);
    }
    std::vector<Row> rows;
    for (const SceneSpec& spec : parsed) {
        if (!scene::isGeneratorSpec(spec.source) && !std::filesystem::exists(spec.source)) {
            fmt::print(stderr, "skipping '{}': file not found\n", spec.source);
            continue;
        }
        auto row = measureScene(*peers, spec, options, width, height);
        if (!row) return errorStatus(row.status().code(),
                                     fmt::format("{}: {}", spec.spec, row.status().message()));
        rows.push_back(*row);
    }
    if (options.json) {
        nlohmann::json out = {{"parallax_threads", peers->parallax->threadCount()},
                              {"parallax_tile_size", options.tileSize},
                              {"parallax_isa", std::string(isaName(activeIsa()))},
                              {"llvmpipe", peers->llvmpipe->rendererName()},
                              {"gl_version", peers->llvmpipe->versionString()},
                              {"lp_num_threads", peers->llvmpipe->threads()},
                              {"width", width},
                              {"height", height},
                              {"warmup", options.warmup},
                              {"frames", options.frames},
                              {"rows", nlohmann::json::array()}};
        for (const Row& r : rows) out["rows"].push_back(rowJson(r));
        fmt::print("{}\n", out.dump(2));
    } else {
        printTable(rows);
    }
    if (csv.is_open()) PLX_RETURN_IF_ERROR(writeCsv(csv, options.csvPath, rows));
    return Status::ok();
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{
        "Parallax's software rasterizer against Mesa llvmpipe (OpenGL 4.5, EGL surfaceless) on "
        "the same scenes: triangles per second of each and their ratio.\n"
        "Example: plx_raster_vs_llvmpipe --size 1280x720 --threads 2 --csv out/peer.csv"};
    Options options;
    app.add_option("--scene", options.scenes,
                   "extra scene: model file, generator spec (office:N), or subdivN:SPEC for SPEC "
                   "midpoint-subdivided N times; a suffix @NAME picks the scene's viewpoint NAME "
                   "(office:64@vista); repeatable");
    app.add_flag("--no-defaults", options.noDefaults,
                 "measure only the --scene list (defaults: office:64 and office:280 from their "
                 "default and vista viewpoints, DamagedHelmet as is and subdivided x16, x64)");
    app.add_option("--size", options.size, "image size WxH")->capture_default_str();
    app.add_option("--threads", options.threads, "threads of each renderer (LP_NUM_THREADS)")
        ->capture_default_str();
    app.add_option("--tile-size", options.tileSize, "Parallax's screen tile side in pixels")
        ->capture_default_str();
    app.add_option("--warmup", options.warmup, "untimed frames of each renderer per scene")
        ->capture_default_str();
    app.add_option("--frames", options.frames, "timed frames of each renderer per scene")
        ->capture_default_str();
    app.add_flag("--json", options.json, "machine-readable result on stdout instead of the table");
    app.add_option("--csv", options.csvPath, "also write the rows to this CSV file");
    app.add_option("--only", options.only,
                   "time one renderer alone, for profiling (the ratio is then not measured)")
        ->check(CLI::IsMember({"parallax", "llvmpipe"}));
    CLI11_PARSE(app, argc, argv);
    Status status = run(options);
    if (!status) {
        fmt::print(stderr, "error: {}\n", status.toString());
        return 1;
    }
    return 0;
}
