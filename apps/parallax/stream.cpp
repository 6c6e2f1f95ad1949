// parallax stream build|merge: the texture-streaming scene database (Marvie & Bouatouch
// sections 3, 5, 6; docs/stream-format.md): cells, PVS and ACH preprocessing, the files.

#include <charconv>
#include <filesystem>

#include <fmt/format.h>

#include <plx/core/file.h>
#include <plx/core/parallel.h>
#include <plx/stream/database.h>

#include "commands.h"
#include "view.h"

namespace plx::cli {
namespace {

struct StreamArgs {
    std::string scene;
    std::string out;
    std::string cells;  // "A-B", empty: all
    int samples = stream::VisibilityConfig{}.samples;
    int faceSize = stream::VisibilityConfig{}.faceSize;
    int threads = 0;
    std::vector<std::string> parts;  // merge
    bool json = false;
};

// "A-B" (decimal, A <= B) -> {A, B}; the message names the text.
Result<std::pair<uint32_t, uint32_t>> parseRange(const std::string& text) {
    uint32_t a = 0, b = 0;
    const char* end = text.data() + text.size();
    auto [p, ec] = std::from_chars(text.data(), end, a);
    if (ec == std::errc() && p < end && *p == '-') {
        auto [q, ec2] = std::from_chars(p + 1, end, b);
        if (ec2 == std::errc() && q == end && a <= b) return std::pair{a, b};
    }
    return errorStatus(ErrorCode::kInvalidArgument,
                       fmt::format("--cells '{}': expected FIRST-LAST, two cell indices with "
                                   "FIRST <= LAST",
                                   text.substr(0, 40)));
}

// Usage checks shared by build and merge, before any work.
Status checkArgs(const StreamArgs& a) {
    if (a.samples < 1 || a.samples > stream::kMaxSamples)
        return errorStatus(
            ErrorCode::kInvalidArgument,
            fmt::format("--samples {} outside 1..{}", a.samples, stream::kMaxSamples));
    if (a.faceSize < stream::kMinFaceSize || a.faceSize > stream::kMaxFaceSize)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--face-size {} outside {}..{}", a.faceSize,
                                       stream::kMinFaceSize, stream::kMaxFaceSize));
    PLX_RETURN_IF_ERROR(checkThreadCount(a.threads, "--threads"));
    std::error_code ec;
    if (std::filesystem::exists(a.out, ec) && !std::filesystem::is_directory(a.out, ec))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--out {}: exists and is not a folder", a.out));
    if (!a.cells.empty()) return parseRange(a.cells).status();
    return Status::ok();
}

// The scene and its cells, loaded under the input policy.
struct Loaded {
    scene::Scene scene;
    stream::Cells cells;
};

Result<Loaded> load(const std::string& spec) {
    auto scene = loadSceneChecked(spec);
    if (!scene) return scene.status();
    auto cells = stream::makeCells(*scene);
    if (!cells) return cells.status();
    return Loaded{std::move(scene).value(), std::move(cells).value()};
}

nlohmann::json pvsSummary(const std::vector<stream::CellVisibility>& vis) {
    size_t sum = 0, most = 0;
    for (const auto& v : vis) {
        size_t n = stream::pvsWithAch(v).size();
        sum += n;
        most = std::max(most, n);
    }
    return {{"pvs_mean", vis.empty() ? 0.0 : double(sum) / double(vis.size())}, {"pvs_max", most}};
}

int runBuild(const StreamArgs& a, const stream::VisibilityConfig& config) {
    Stopwatch total;
    auto loaded = load(a.scene);
    if (!loaded) return fail(loaded.status());
    const uint32_t cellCount = uint32_t(loaded->cells.boxes.size());
    uint32_t first = 0, last = cellCount - 1;
    if (!a.cells.empty()) {
        auto range = parseRange(a.cells).value();
        if (range.second >= cellCount)
            return fail(fmt::format("--cells {}: the scene has cells 0-{}", a.cells, cellCount - 1),
                        kExitUsage);
        std::tie(first, last) = range;
    }
    std::optional<Progress> progress;
    if (!a.json) progress.emplace("pvs", last - first + 1);
    Stopwatch pvsClock;
    auto vis =
        stream::computeVisibility(loaded->scene, loaded->cells, config, first, last, [&](size_t) {
            if (progress) progress->step();
        });
    if (!vis) return fail(vis.status());
    const double pvsSeconds = pvsClock.elapsedMs() / 1000.0;
    progress.reset();
    nlohmann::json doc = {{"scene", a.scene},
                          {"scene_cells", cellCount},
                          {"cells", vis->size()},
                          {"first", first},
                          {"last", last},
                          {"samples", config.samples},
                          {"face_size", config.faceSize},
                          {"cells_from", loaded->cells.fromRooms ? "rooms" : "kd"},
                          {"pvs_seconds", pvsSeconds},
                          {"cells_per_s", double(vis->size()) / std::max(pvsSeconds, 1e-9)}};
    doc.update(pvsSummary(*vis));
    if (!a.cells.empty()) {
        stream::PartFile part{stream::sceneHash(loaded->scene, loaded->cells),
                              cellCount,
                              first,
                              last,
                              config.samples,
                              config.faceSize,
                              std::move(vis).value()};
        const std::string name = fmt::format("part-{}-{}.json", first, last);
        const std::string text = stream::serializePart(part);
        Status s = stream::writeBelow(a.out, name,
                                      {reinterpret_cast<const uint8_t*>(text.data()), text.size()});
        if (!s) return fail(s);
        doc.update({{"part", name}, {"textures", 0}, {"bytes", text.size()}});
    } else {
        auto stats =
            stream::writeDatabase(loaded->scene, loaded->cells, *vis, config, a.scene, a.out);
        if (!stats) return fail(stats.status());
        doc.update({{"textures", stats->textures},
                    {"bytes", stats->bytes},
                    {"texture_bytes", stats->textureBytes},
                    {"geometry_bytes", stats->geometryBytes}});
    }
    doc["seconds"] = total.elapsedMs() / 1000.0;
    if (a.json) {
        printJson(doc);
    } else {
        fmt::print(
            "{}: {} of {} cells ({}), PVS mean {:.1f} max {}, {:.1f} cells/s; {} bytes "
            "in {}\n",
            a.scene, doc["cells"].get<size_t>(), cellCount, doc["cells_from"].get<std::string>(),
            doc["pvs_mean"].get<double>(), doc["pvs_max"].get<size_t>(),
            doc["cells_per_s"].get<double>(), doc["bytes"].get<uint64_t>(), a.out);
    }
    return kExitOk;
}

int runMerge(const StreamArgs& a) {
    auto loaded = load(a.scene);
    if (!loaded) return fail(loaded.status());
    std::vector<stream::PartFile> parts;
    for (const std::string& path : a.parts) {
        auto text = readFileChecked(path, stream::kMaxPartBytes);
        if (!text) return fail(text.status());
        auto part =
            stream::parsePart({reinterpret_cast<const uint8_t*>(text->data()), text->size()});
        if (!part) return fail(fmt::format("{}: {}", path, part.status().message()));
        parts.push_back(std::move(part).value());
    }
    const uint32_t cellCount = uint32_t(loaded->cells.boxes.size());
    auto vis =
        stream::mergeParts(parts, stream::sceneHash(loaded->scene, loaded->cells), cellCount);
    if (!vis) return fail(vis.status());
    stream::VisibilityConfig sampling;
    sampling.samples = parts[0].samples;
    sampling.faceSize = parts[0].faceSize;
    auto stats =
        stream::writeDatabase(loaded->scene, loaded->cells, *vis, sampling, a.scene, a.out);
    if (!stats) return fail(stats.status());
    if (a.json)
        printJson({{"scene", a.scene},
                   {"parts", parts.size()},
                   {"cells", stats->cells},
                   {"textures", stats->textures},
                   {"bytes", stats->bytes}});
    else
        fmt::print("{}: {} parts merged, {} cells, {} textures, {} bytes in {}\n", a.scene,
                   parts.size(), stats->cells, stats->textures, stats->bytes, a.out);
    return kExitOk;
}

int runStream(const StreamArgs& a, bool merge) {
    if (Status s = checkArgs(a); !s) return fail(s.message(), kExitUsage);
    stream::VisibilityConfig config;
    config.samples = a.samples;
    config.faceSize = a.faceSize;
    config.threads = a.threads;
    int code = kExitOk;
    ThreadPool pool(a.threads);
    pool.run([&] { code = merge ? runMerge(a) : runBuild(a, config); });
    return code;
}

}  // namespace

Command registerStream(CLI::App& app) {
    auto a = std::make_shared<StreamArgs>();
    CLI::App* sub = app.add_subcommand(
        "stream", "Texture streaming: build the scene database (cells, PVS, ACH, PTM files)");
    sub->require_subcommand(1);
    sub->footer(
        "Example: parallax stream build museum:16 --out out/m16 && "
        "parallax stream walk out/m16 --tour --bandwidth 56 --json");
    CLI::App* build = sub->add_subcommand(
        "build", "Cells, their PVS and ACHs (Marvie & Bouatouch section 5), and the database");
    build->footer(
        "Example: parallax stream build museum:64 --out out/museum64 --json\n"
        "Writes DIR/root.json, DIR/cells/*.json|glb, DIR/textures/*.ptm (docs/stream-format.md). "
        "With --cells A-B only the PVS of cells A..B, as DIR/part-A-B.json, for `stream merge`.\n"
        "JSON: cells (computed), cells_per_s (PVS stage), textures, bytes (all files), pvs_mean, "
        "pvs_max.");
    CLI::App* merge = sub->add_subcommand(
        "merge", "Join range builds (part files) of one scene into the whole database");
    merge->footer(
        "Example: parallax stream merge museum:64 --out out/museum64 out/p/part-0-31.json "
        "out/p/part-32-63.json");
    for (CLI::App* c : {build, merge}) {
        c->add_option("scene", a->scene, "Model file or generator spec (museum:N, office:N)")
            ->required();
        c->add_option("--out", a->out, "Database folder (created; nothing is written outside)")
            ->required()
            ->check(outputPath(OutputKind::kFolder));
        c->add_option("--threads", a->threads, "Worker threads (0: all cores)");
        c->add_flag("--json", a->json, "Print a JSON result on stdout");
    }
    build->add_option("--cells", a->cells, "Compute cells FIRST-LAST only (a part file)");
    build->add_option("--samples", a->samples, "Sample points (rendering boxes) per cell")
        ->capture_default_str();
    build->add_option("--face-size", a->faceSize, "Pixels per side of each camera face")
        ->capture_default_str();
    merge->add_option("parts", a->parts, "Part files written by stream build --cells")->required();
    return registerStreamWalk(sub, {sub, [a, merge] { return runStream(*a, merge->parsed()); }});
}

}  // namespace plx::cli
