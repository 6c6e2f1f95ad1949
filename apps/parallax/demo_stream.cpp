// The demo's texture-streaming section (Marvie & Bouatouch sections 5-7): a museum database built
// with cells, PVS and coverage hints, walked through every room on the simulated link at four
// bandwidths; the progressive downloading quality over time (the paper's Fig. 2), the resident
// bytes against the budget, and frames at the paper's Fig. 3 moments at 56 kbit/s.

#include <algorithm>
#include <cmath>
#include <map>

#include <fmt/format.h>

#include <plx/raster/raster.h>
#include <plx/scene/generators.h>
#include <plx/stream/client.h>
#include <plx/stream/database.h>
#include <plx/stream/link_simulator.h>

#include "cli.h"
#include "demo.h"

namespace plx::cli {

namespace {

constexpr float kEyeHeight = 1.6f;
constexpr double kFps = 30.0;
constexpr double kSpeed = 1.2;  // metres per second between rooms

// Every room in serpentine order by centre (rows along z, alternating x), walking between
// centres at eye height and standing still `stopS` in each (the static-viewpoint case), looking
// along the walk: the tour of section 7.1, as scripts/stream_walk_path.py writes it.
std::vector<Camera> roomTour(const stream::Cells& cells, double stopS, int width, int height) {
    std::map<float, std::vector<Vec3>> rows;
    for (const Aabb& b : cells.boxes) {
        Vec3 c = 0.5f * (b.lo + b.hi);
        rows[std::round(c.z * 1000.0f) / 1000.0f].push_back(c);
    }
    std::vector<Vec3> order;
    bool reverse = false;
    for (auto& [z, row] : rows) {
        std::sort(row.begin(), row.end(),
                  [&](Vec3 a, Vec3 b) { return reverse ? a.x > b.x : a.x < b.x; });
        order.insert(order.end(), row.begin(), row.end());
        reverse = !reverse;
    }
    std::vector<Camera> cameras;
    Vec3 heading(1.0f, 0.0f, 0.0f);
    auto add = [&](Vec3 at) {
        CameraDesc d;
        d.eyePos = {at.x, kEyeHeight, at.z};
        d.targetPos = d.eyePos + 5.0f * heading;
        d.width = width, d.height = height;
        d.farPlane = 200.0f;
        cameras.push_back(Camera::create(d).value());
    };
    Vec3 here = order.front();
    const float step = float(kSpeed / kFps);
    for (Vec3 next : order) {
        Vec3 delta(next.x - here.x, 0.0f, next.z - here.z);
        const float distance = glm::length(delta);
        if (distance > 1e-6f) heading = delta / distance;
        for (int k = 0; k < int(distance / step); ++k)
            add(here + delta * (float(k) * step / distance));
        here = next;
        for (int k = 0; k < int(stopS * kFps); ++k) add(here);
    }
    return cameras;
}

struct Setting {
    double kbit;  // 0: unlimited
    std::string name;
};

struct WalkCurve {
    std::vector<std::pair<double, double>> quality;   // (seconds, %)
    std::vector<std::pair<double, double>> resident;  // (seconds, MiB)
    double final = 0.0, firstAt90 = -1.0;
    uint64_t maxResident = 0, downloaded = 0, failed = 0;
};

}  // namespace

Status demoStreamSection(DemoContext& ctx) {
    HtmlReport& rep = *ctx.report;
    const std::string spec = "museum:4";
    auto scene = scene::generateFromSpec(spec);
    if (!scene) return scene.status();
    auto cells = stream::makeCells(*scene);
    if (!cells) return cells.status();
    stream::VisibilityConfig sampling;
    if (ctx.quick) sampling.samples = 2, sampling.faceSize = 32;
    const uint32_t last = uint32_t(cells->boxes.size() - 1);
    Progress progress("demo: texture streaming", 5);
    auto visibility = stream::computeVisibility(*scene, *cells, sampling, 0, last);
    if (!visibility) return visibility.status();
    const std::string db = ctx.outDir + "/stream_db";
    auto built = stream::writeDatabase(*scene, *cells, *visibility, sampling, spec, db);
    if (!built) return built.status();
    progress.step();

    const int width = ctx.quick ? 80 : 320, height = ctx.quick ? 60 : 240;
    const std::vector<Camera> tour = roomTour(*cells, ctx.quick ? 1.0 : 15.0, width, height);
    const double shotTimes[] = {10.0, 35.0, 80.0};  // Fig. 3's moments
    stream::ClientConfig config;
    config.budgetBytes = uint64_t(1) << 20;
    config.staticBudgetBytes = uint64_t(4) << 20;
    const std::vector<Setting> settings = {
        {56, "56 kbit/s"}, {1000, "1 Mbit/s"}, {10000, "10 Mbit/s"}, {0, "unlimited"}};

    auto renderer = raster::Renderer::create({ctx.threads});
    if (!renderer) return renderer.status();
    raster::FrameBuffers buffers;
    buffers.resize(width, height);
    raster::RenderOptions options;
    options.shading = raster::Shading::kTextured;
    std::vector<std::pair<std::string, std::string>> shots;

    std::vector<WalkCurve> curves;
    for (const Setting& s : settings) {
        stream::LinkSimulator link(db, {s.kbit * 1e3, 0.05});
        stream::StreamClient client(&link, config);
        WalkCurve curve;
        size_t nextShot = 0;
        stream::FrameReport report;
        for (size_t i = 0; i < tour.size(); ++i) {
            report = client.frame(tour[i], double(i) / kFps);
            if (i % 15 == 0) {
                curve.quality.emplace_back(report.timeS, 100.0 * report.quality);
                curve.resident.emplace_back(report.timeS, double(report.residentBytes) / (1 << 20));
            }
            if (curve.firstAt90 < 0.0 && report.quality >= 0.9) curve.firstAt90 = report.timeS;
            curve.maxResident = std::max(curve.maxResident, report.residentBytes);
            // The paper's screenshots come from the slowest link.
            if (s.kbit == 56 && nextShot < std::size(shotTimes) &&
                report.timeS >= shotTimes[nextShot]) {
                auto drawn = client.residentScene();
                if (drawn) (*renderer)->render(*drawn, tour[i], options, buffers.targets());
                const std::string file = fmt::format("stream_{:02}s.png", int(shotTimes[nextShot]));
                PLX_RETURN_IF_ERROR(writePng(ctx.outDir + "/" + file, buffers.color));
                shots.emplace_back(file, fmt::format("56 kbit/s at {:g} s: quality {:.0f}%",
                                                     shotTimes[nextShot], 100.0 * report.quality));
                ++nextShot;
            }
        }
        curve.final = report.quality;
        curve.downloaded = report.downloadedBytes;
        curve.failed = client.failedRequests();
        curves.push_back(std::move(curve));
        progress.step();
    }

    rep.heading("Texture streaming under a memory budget (Marvie, Bouatouch)");
    rep.paragraph(fmt::format(
        "{} split into {} cells (its rooms); each cell's potentially visible set and average "
        "coverage hints come from {} sample points with six 90-degree ID renders each. The "
        "database ({:.1f} MB: {} PTM textures, one glTF binary per cell) is walked through every "
        "room ({:.0f} s at 30 fps, {:g} s still in each room) over a simulated link with 50 ms "
        "latency per request; the client splits a {} MiB budget (moving) or {} MiB (static) by the "
        "hints and keeps only the PTM levels that fit. Quality is the paper's progressive "
        "downloading quality: downloaded levels over the levels of the textures in view.",
        spec, cells->boxes.size(), sampling.samples, double(built->bytes) / 1e6, built->textures,
        double(tour.size()) / kFps, ctx.quick ? 1.0 : 15.0, config.budgetBytes >> 20,
        config.staticBudgetBytes >> 20));
    std::vector<PlotSeries> quality, resident;
    for (size_t k = 0; k < settings.size(); ++k) {
        quality.push_back({settings[k].name, curves[k].quality});
        resident.push_back({settings[k].name, curves[k].resident});
    }
    const std::string qualityPlot =
        svgLinePlot({"Progressive downloading quality (Fig. 2)", "time s", "quality %"}, quality);
    const std::string residentPlot = svgLinePlot(
        {"Resident texture bytes (budget 1 MiB moving, 4 MiB still)", "time s", "MiB"}, resident);
    PLX_RETURN_IF_ERROR(writeText(ctx.outDir + "/stream_quality.svg", qualityPlot));
    PLX_RETURN_IF_ERROR(writeText(ctx.outDir + "/stream_resident.svg", residentPlot));
    rep.raw("<div class='row'>" + qualityPlot + residentPlot + "</div>");
    if (!shots.empty()) rep.images(shots);

    std::vector<std::vector<std::string>> table;
    nlohmann::json rows = nlohmann::json::array();
    for (size_t k = 0; k < settings.size(); ++k) {
        const WalkCurve& c = curves[k];
        table.push_back({settings[k].name, fmt::format("{:.1f}", 100.0 * c.final),
                         c.firstAt90 < 0.0 ? "never" : fmt::format("{:.1f}", c.firstAt90),
                         fmt::format("{} / {}", c.maxResident, config.staticBudgetBytes),
                         fmt::format("{:.2f}", double(c.downloaded) / 1e6),
                         std::to_string(c.failed)});
        rows.push_back({{"bandwidth_kbit", settings[k].kbit},
                        {"quality_final", c.final},
                        {"time_to_quality_90_s", c.firstAt90},
                        {"max_resident_bytes", c.maxResident},
                        {"budget_bytes", config.staticBudgetBytes},
                        {"downloaded_bytes", c.downloaded}});
    }
    rep.table({"link", "final quality %", "first >= 90% at s", "max resident / budget bytes",
               "downloaded MB", "failed requests"},
              table);
    (*ctx.summary)["stream"] = {{"scene", spec},
                                {"cells", cells->boxes.size()},
                                {"database_bytes", built->bytes},
                                {"walks", rows}};
    return Status::ok();
}

}  // namespace plx::cli
