// The experiment of Heo, Jung, Wohn (Table 1, Fig. 17): full pipeline against the P-buffer
// method on office:N, and the reproject method of Fu, Bao, Peng beside them, timed pair by pair.

#include "experiment_stereo.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include <fmt/format.h>

#include <plx/scene/generators.h>

#include "cli.h"
#include "hole_classes.h"
#include "report.h"

namespace plx::cli {

namespace {

struct MethodTiming {
    std::vector<double> first, second, collect, reproject, fill;
    stereo::StereoFrameStats last;
    std::vector<uint32_t> drawn;  // drawnSet of the quality frame

    void add(const stereo::StereoFrameStats& st) {
        last = st;
        first.push_back(st.firstEyeMs);
        second.push_back(st.secondEyeMs);
        collect.push_back(st.collectMs);
        reproject.push_back(st.reprojectMs);
        fill.push_back(st.fillMs);
    }
};

// Times the methods frame by frame in turn after one warm-up pair each, so that load from other
// processes falls on all of them alike. The order rotates every frame (full, pbuffer,
// conservative, reproject; then pbuffer, conservative, reproject, full; ...): a method's first eye
// finds the caches as the method before it left them (a full pass over the scene, or a small
// subset), and a fixed order gave the method after the full one a first eye up to 0.5 ms slower at
// 1M triangles, with the same renderer and the same scene. The timed frames write colour only
// (StereoOptions::writeDepthAndIds): what a display shows, and neither method then pays for 2.5 MB
// of depth and IDs per eye that nobody reads.
void timeMethods(stereo::StereoRenderer& renderer, const scene::Scene& scene, const StereoRig& rig,
                 const std::vector<stereo::StereoOptions>& options, int frames,
                 std::vector<stereo::StereoFrame>* out, std::vector<MethodTiming>* timings) {
    timings->assign(options.size(), {});
    for (int f = -1; f < frames; ++f) {
        for (size_t turn = 0; turn < options.size(); ++turn) {
            const size_t m = (turn + size_t(f + 1)) % options.size();
            stereo::StereoOptions timed = options[m];
            timed.writeDepthAndIds = false;
            stereo::StereoFrameStats st = renderer.renderPair(scene, rig, timed, &(*out)[m]);
            if (f >= 0) (*timings)[m].add(st);
        }
    }
}

// One more pair of each method, untimed, with the depth and IDs that compareSecondEye reads (the
// colour is the timed frames' own: rendering is deterministic).
void renderForQuality(stereo::StereoRenderer& renderer, const scene::Scene& scene,
                      const StereoRig& rig, const std::vector<stereo::StereoOptions>& options,
                      std::vector<stereo::StereoFrame>* out, std::vector<MethodTiming>* timings) {
    for (size_t m = 0; m < options.size(); ++m) {
        renderer.renderPair(scene, rig, options[m], &(*out)[m]);
        (*timings)[m].drawn = drawnSet(renderer, options[m].method, (*out)[m].eye(rig.secondEye()));
    }
}

// Where each method sits in the options, frames and timings of one row; -1: not measured.
struct MethodSlots {
    int full = 0, pbuffer = 1, conservative = -1, reproject = -1;
};

std::vector<stereo::StereoOptions> methodOptions(const StereoExperimentConfig& config,
                                                 MethodSlots* slots) {
    std::vector<stereo::StereoOptions> options(2);
    options[0].method = stereo::Method::kFull;
    options[1].method = stereo::Method::kPBuffer;
    if (config.conservative) {
        slots->conservative = int(options.size());
        options.emplace_back().method = stereo::Method::kPBuffer;
        options.back().conservative = true;
    }
    if (config.reproject) {
        slots->reproject = int(options.size());
        options.emplace_back().method = stereo::Method::kReproject;
    }
    for (auto& o : options) o.render.shading = config.shading;
    return options;
}

void fillPbufferColumns(const MethodTiming& full, const MethodTiming& t,
                        const stereo::SecondEyeQuality& q, StereoExperimentRow* row) {
    row->visiblePolygons = t.last.visibleTriangles;
    row->fullFirstMs = median(full.first);
    row->fullSecondMs = median(full.second);
    row->pbufferFirstMs = median(t.first);
    row->pbufferSecondMs = median(t.second);
    row->collectMs = median(t.collect);
    row->pairSpeedup = (row->fullFirstMs + row->fullSecondMs) /
                       (row->pbufferFirstMs + row->collectMs + row->pbufferSecondMs);
    row->secondEyePsnrDb = q.psnrDb;
    row->differingFraction = q.differingFraction;
    row->missedPolygons = q.missedPolygons;
    row->missedPixels = q.missedPixels;
}

void fillConservativeColumns(const MethodTiming& t, const stereo::SecondEyeQuality& q,
                             StereoExperimentRow* row) {
    row->conservativeExtra = t.last.conservativeExtra;
    row->conservativeFirstMs = median(t.first);
    row->conservativeSecondMs = median(t.second) + median(t.collect);
    row->conservativePsnrDb = q.psnrDb;
    row->conservativeMissedPolygons = q.missedPolygons;
    row->conservativeMissedPixels = q.missedPixels;
}

// After fillPbufferColumns (the full method's times).
void fillReprojectColumns(const MethodTiming& t, const stereo::SecondEyeQuality& q, int pixels,
                          StereoExperimentRow* row) {
    row->reprojectFirstMs = median(t.first);
    row->reprojectSecondMs = median(t.second);
    row->reprojectMs = median(t.reproject);
    row->fillMs = median(t.fill);
    row->reprojectPairSpeedup =
        (row->fullFirstMs + row->fullSecondMs) / (row->reprojectFirstMs + row->reprojectSecondMs);
    row->reprojectPsnrDb = q.psnrDb;
    row->reprojectIdenticalFraction = 1.0 - q.differingFraction;
    row->reprojectHoleFraction = double(t.last.holePixels) / double(std::max(1, pixels));
    row->reprojectExpansionHoles = t.last.expansionHoles;
    row->reprojectDisocclusionHoles = t.last.disocclusionHoles;
    row->reprojectFillPolygonsDrawn = t.last.fillPolygonsDrawn;
    row->reprojectMissedPixels = q.missedPixels;
}

// One row: office:n timed with every method, then its quality against the full method.
Result<StereoExperimentRow> measureRow(stereo::StereoRenderer& renderer,
                                       const StereoExperimentConfig& config, int n) {
    auto scene = scene::generateOffice(n);
    if (!scene) return scene.status();
    auto center =
        scene::cameraAt(*scene, scene::defaultViewpoint(*scene), config.width, config.height);
    if (!center) return center.status();
    auto rig = StereoRig::create(*center, config.rig);
    if (!rig) return rig.status();
    StereoExperimentRow row;
    row.rooms = n;
    row.polygons = scene->triangleCount();
    MethodSlots slot;
    std::vector<stereo::StereoOptions> options = methodOptions(config, &slot);
    if (slot.reproject >= 0) {
        PLX_RETURN_IF_ERROR(renderer.prepareReprojection(*scene));
        row.reprojectPrepareMs = renderer.lastPrepareMs();
    }
    std::vector<stereo::StereoFrame> frames(options.size());
    std::vector<MethodTiming> t;
    timeMethods(renderer, *scene, *rig, options, config.frames, &frames, &t);
    // As `stereo` does: blank images would follow, and a perfect score (99 dB, 1.8x).
    if (t[size_t(slot.pbuffer)].last.visibleTriangles == 0)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("office:{}: the first eye sees none of the scene (check "
                                       "--separation, --convergence)",
                                       n));
    renderForQuality(renderer, *scene, *rig, options, &frames, &t);
    Eye second = rig->secondEye();
    auto quality = [&](int m) {
        return stereo::compareSecondEye(frames[size_t(m)].eye(second),
                                        frames[size_t(slot.full)].eye(second), t[size_t(m)].drawn);
    };
    fillPbufferColumns(t[size_t(slot.full)], t[size_t(slot.pbuffer)], quality(slot.pbuffer), &row);
    if (slot.conservative >= 0)
        fillConservativeColumns(t[size_t(slot.conservative)], quality(slot.conservative), &row);
    if (slot.reproject >= 0)
        fillReprojectColumns(t[size_t(slot.reproject)], quality(slot.reproject),
                             config.width * config.height, &row);
    return row;
}

}  // namespace

// Bytes per pixel: the growth of the peak from 1024x1024 to 2048x2048 (office:1) is 52.2 with
// the full and P-buffer methods alone, the conservative set adds 49.1-53.0 and the reprojection
// 38.7-42.6 (with and without the other). Rounded up; MemoryCli.EstimatesHoldTheMeasuredPeak
// holds them to the peak.
double stereoExperimentImageBytes(const StereoExperimentConfig& config) {
    const double perPixel =
        55.0 + (config.conservative ? 53.0 : 0.0) + (config.reproject ? 43.0 : 0.0);
    return perPixel * double(config.width) * double(config.height);
}

double stereoExperimentSceneBytes(const StereoExperimentConfig& config) {
    std::vector<int> rooms = config.rooms;
    std::sort(rooms.begin(), rooms.end(), std::greater<>());
    if (rooms.empty()) return 0.0;
    auto officeTriangles = [](int n) {
        auto triangles = scene::generatedTriangleBound(fmt::format("office:{}", n));
        return triangles ? double(*triangles) : 0.0;
    };
    const double working =
        kRenderBytesPerTriangle + (config.reproject ? kReprojectBoxesBytesPerTriangle : 0.0);
    const double largest = officeTriangles(rooms[0]);
    const double before = rooms.size() > 1 ? officeTriangles(rooms[1]) : 0.0;
    return kRenderFixedBytes + largest * (kGeneratedSceneBytesPerTriangle + working) +
           before * working;
}

Result<std::vector<StereoExperimentRow>> runStereoExperiment(
    const StereoExperimentConfig& config, const std::function<void(size_t, size_t)>& progress) {
    if (config.rooms.empty() || config.frames < 1 || config.width < 1 || config.height < 1)
        return errorStatus(ErrorCode::kInvalidArgument,
                           "stereo experiment needs rooms, frames "
                           "and a size");
    auto renderer = stereo::StereoRenderer::create({config.threads});
    if (!renderer) return renderer.status();
    std::vector<StereoExperimentRow> rows;
    for (size_t i = 0; i < config.rooms.size(); ++i) {
        auto row = measureRow(**renderer, config, config.rooms[i]);
        if (!row) return row.status();
        rows.push_back(*row);
        if (progress) progress(i + 1, config.rooms.size());
    }
    return rows;
}

namespace {
double finiteOr(double v, double fallback) {
    return std::isfinite(v) ? v : fallback;
}
}  // namespace

nlohmann::json stereoExperimentJson(const StereoExperimentConfig& config,
                                    const std::vector<StereoExperimentRow>& rows) {
    nlohmann::json out = {{"width", config.width},
                          {"height", config.height},
                          {"frames", config.frames},
                          {"separation", shortestDecimal(config.rig.separation)},
                          {"convergence", shortestDecimal(config.rig.convergence)},
                          {"threads", config.threads},
                          {"conservative", config.conservative},
                          {"reproject", config.reproject},
                          {"rows", nlohmann::json::array()}};
    for (const auto& r : rows) {
        // PSNR of identical images is infinite; JSON has no infinity, so report 99 dB (and say
        // so in the field name's documentation).
        out["rows"].push_back({{"rooms", r.rooms},
                               {"polygons", r.polygons},
                               {"visible_polygons", r.visiblePolygons},
                               {"full_first_ms", r.fullFirstMs},
                               {"full_second_ms", r.fullSecondMs},
                               {"pbuffer_first_ms", r.pbufferFirstMs},
                               {"pbuffer_collect_ms", r.collectMs},
                               {"pbuffer_second_ms", r.pbufferSecondMs},
                               {"pair_speedup", r.pairSpeedup},
                               {"second_eye_psnr_db", finiteOr(r.secondEyePsnrDb, 99.0)},
                               {"differing_fraction", r.differingFraction},
                               {"missed_polygons", r.missedPolygons},
                               {"missed_pixels", r.missedPixels},
                               {"conservative_extra_polygons", r.conservativeExtra},
                               {"conservative_first_ms", r.conservativeFirstMs},
                               {"conservative_second_ms", r.conservativeSecondMs},
                               {"conservative_psnr_db", finiteOr(r.conservativePsnrDb, 99.0)},
                               {"conservative_missed_polygons", r.conservativeMissedPolygons},
                               {"conservative_missed_pixels", r.conservativeMissedPixels},
                               {"reproject_prepare_ms", r.reprojectPrepareMs},
                               {"reproject_first_ms", r.reprojectFirstMs},
                               {"reproject_second_ms", r.reprojectSecondMs},
                               {"reproject_ms", r.reprojectMs},
                               {"fill_ms", r.fillMs},
                               {"reproject_pair_speedup", r.reprojectPairSpeedup},
                               {"reproject_psnr_db", finiteOr(r.reprojectPsnrDb, 99.0)},
                               {"reproject_identical_fraction", r.reprojectIdenticalFraction},
                               {"reproject_hole_fraction", r.reprojectHoleFraction},
                               {"reproject_expansion_holes", r.reprojectExpansionHoles},
                               {"reproject_disocclusion_holes", r.reprojectDisocclusionHoles},
                               {"reproject_fill_polygons_drawn", r.reprojectFillPolygonsDrawn},
                               {"reproject_missed_pixels", r.reprojectMissedPixels}});
        // The columns of a measurement the run skipped are null, not a 0 that reads as data.
        for (auto [key, value] : out["rows"].back().items()) {
            const bool conservative = key.starts_with("conservative_");
            const bool reproject = key.starts_with("reproject_") || key == "fill_ms";
            if ((conservative && !config.conservative) || (reproject && !config.reproject))
                value = nullptr;
        }
    }
    return out;
}

std::string stereoExperimentCsv(const StereoExperimentConfig& config,
                                const std::vector<StereoExperimentRow>& rows) {
    std::string csv =
        "rooms,polygons,visible_polygons,full_first_ms,full_second_ms,pbuffer_first_ms,"
        "pbuffer_collect_ms,pbuffer_second_ms,pair_speedup,second_eye_psnr_db,differing_fraction,"
        "missed_polygons,missed_pixels,conservative_extra_polygons,conservative_first_ms,"
        "conservative_second_ms,conservative_psnr_db,conservative_missed_polygons,"
        "conservative_missed_pixels,reproject_prepare_ms,reproject_first_ms,reproject_second_ms,"
        "reproject_ms,fill_ms,reproject_pair_speedup,reproject_psnr_db,reproject_identical_"
        "fraction,"
        "reproject_hole_fraction,reproject_expansion_holes,reproject_disocclusion_holes,"
        "reproject_fill_polygons_drawn,reproject_missed_pixels\n";
    // A skipped measurement's columns are left empty (its six and thirteen columns).
    const std::string noConservative(5, ','), noReproject(12, ',');
    for (const auto& r : rows) {
        csv += fmt::format(
            "{},{},{},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.2f},{:.6f},{},{},", r.rooms,
            r.polygons, r.visiblePolygons, r.fullFirstMs, r.fullSecondMs, r.pbufferFirstMs,
            r.collectMs, r.pbufferSecondMs, r.pairSpeedup, finiteOr(r.secondEyePsnrDb, 99.0),
            r.differingFraction, r.missedPolygons, r.missedPixels);
        csv += config.conservative
                   ? fmt::format("{},{:.3f},{:.3f},{:.2f},{},{},", r.conservativeExtra,
                                 r.conservativeFirstMs, r.conservativeSecondMs,
                                 finiteOr(r.conservativePsnrDb, 99.0), r.conservativeMissedPolygons,
                                 r.conservativeMissedPixels)
                   : noConservative + ",";
        csv +=
            config.reproject
                ? fmt::format(
                      "{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.2f},{:.6f},{:.6f},{},"
                      "{},{},{}\n",
                      r.reprojectPrepareMs, r.reprojectFirstMs, r.reprojectSecondMs, r.reprojectMs,
                      r.fillMs, r.reprojectPairSpeedup, finiteOr(r.reprojectPsnrDb, 99.0),
                      r.reprojectIdenticalFraction, r.reprojectHoleFraction,
                      r.reprojectExpansionHoles, r.reprojectDisocclusionHoles,
                      r.reprojectFillPolygonsDrawn, r.reprojectMissedPixels)
                : noReproject + "\n";
    }
    return csv;
}

std::vector<std::pair<std::string, std::string>> stereoPlots(
    const std::vector<StereoExperimentRow>& rows) {
    PlotSeries fullFirst{"full pipeline", {}}, pbufFirst{"p-buffer method", {}};
    PlotSeries fullSecond{"full pipeline", {}}, pbufSecond{"p-buffer method", {}};
    PlotSeries fullPair{"full pipeline", {}}, pbufPair{"p-buffer method", {}};
    PlotSeries speedup{"pair speedup (full / p-buffer)", {}}, visible{"visible polygons", {}};
    PlotSeries reprojectSecond{"reproject method", {}};
    const bool withReproject = !rows.empty() && rows.front().reprojectSecondMs > 0.0;
    for (const auto& r : rows) {
        double n = double(r.polygons);
        fullFirst.points.emplace_back(n, r.fullFirstMs);
        pbufFirst.points.emplace_back(n, r.pbufferFirstMs);
        fullSecond.points.emplace_back(n, r.fullSecondMs);
        pbufSecond.points.emplace_back(n, r.pbufferSecondMs + r.collectMs);
        fullPair.points.emplace_back(n, r.fullFirstMs + r.fullSecondMs);
        pbufPair.points.emplace_back(n, r.pbufferFirstMs + r.collectMs + r.pbufferSecondMs);
        speedup.points.emplace_back(n, r.pairSpeedup);
        visible.points.emplace_back(n, double(r.visiblePolygons));
        reprojectSecond.points.emplace_back(n, r.reprojectSecondMs);
    }
    auto spec = [](const char* title, const char* y) {
        return PlotSpec{title, "polygons (log scale)", y, true, true};
    };
    std::vector<PlotSeries> secondEyes = {fullSecond, pbufSecond};
    if (withReproject) secondEyes.push_back(reprojectSecond);
    return {
        {"second_eye_methods.svg",
         svgLinePlot(spec("Second eye of each method (reproject: reproject + fill)", "ms"),
                     secondEyes)},
        {"fig17a_first_eye.svg",
         svgLinePlot(spec("Fig. 17(a): first eye", "ms"), {fullFirst, pbufFirst})},
        {"fig17b_second_eye.svg",
         svgLinePlot(spec("Fig. 17(b): second eye (p-buffer: collect + subset)", "ms"),
                     {fullSecond, pbufSecond})},
        {"fig17c_pair.svg", svgLinePlot(spec("Fig. 17(c): both eyes", "ms"), {fullPair, pbufPair})},
        {"speedup.svg", svgLinePlot(spec("Pair speedup of the p-buffer method", "x"), {speedup})},
        {"visible.svg", svgLinePlot(spec("Visible polygons (first eye)", "polygons"), {visible})},
    };
}

namespace {
// 1016960 -> "1,016,960", as the results pages write counts.
std::string withCommas(size_t n) {
    std::string digits = std::to_string(n), out;
    for (size_t i = 0; i < digits.size(); ++i) {
        if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
        out += digits[i];
    }
    return out;
}

std::string markdownTable(const std::vector<std::string>& header,
                          const std::vector<std::vector<std::string>>& rows) {
    std::string out = "|", rule = "|";
    for (const std::string& h : header) {
        out += " " + h + " |";
        rule += " ---: |";
    }
    out += "\n" + rule + "\n";
    for (const auto& row : rows) {
        out += "|";
        for (const std::string& cell : row) out += " " + cell + " |";
        out += "\n";
    }
    return out;
}
}  // namespace

std::string stereoMethodsMarkdown(const std::vector<StereoExperimentRow>& rows) {
    std::vector<std::vector<std::string>> cells;
    for (const auto& r : rows)
        cells.push_back(
            {fmt::format("{}", r.rooms), withCommas(r.polygons),
             fmt::format("{:.2f}", r.fullSecondMs),
             fmt::format("{:.2f}", r.pbufferSecondMs + r.collectMs),
             fmt::format("{:.2f} ({:.2f} + {:.2f})", r.reprojectSecondMs, r.reprojectMs, r.fillMs),
             fmt::format("{:.2f}x", r.pairSpeedup), fmt::format("{:.2f}x", r.reprojectPairSpeedup),
             fmt::format("{:.1f}", finiteOr(r.secondEyePsnrDb, 99.0)),
             fmt::format("{:.1f}", finiteOr(r.reprojectPsnrDb, 99.0)),
             fmt::format("{:.4f}", r.reprojectIdenticalFraction),
             fmt::format("{:.4f}", r.reprojectHoleFraction),
             withCommas(r.reprojectFillPolygonsDrawn)});
    return markdownTable({"rooms", "polygons", "full 2nd ms", "p-buffer 2nd ms",
                          "reproject 2nd ms (reproject + fill)", "p-buffer pair speedup",
                          "reproject pair speedup", "p-buffer PSNR dB", "reproject PSNR dB",
                          "reproject identical", "reproject holes", "fill polygons drawn"},
                         cells);
}

std::string reprojectPaperTableMarkdown(const std::vector<StereoExperimentRow>& rows) {
    std::vector<std::vector<std::string>> cells;
    for (const auto& r : rows)
        cells.push_back({withCommas(r.polygons), fmt::format("{:.2f}", r.reprojectFirstMs),
                         fmt::format("{:.2f}", r.reprojectSecondMs),
                         fmt::format("{:.2f}", r.reprojectFirstMs + r.reprojectSecondMs),
                         fmt::format("{:.0f}", r.reprojectPrepareMs)});
    return markdownTable(
        {"polygons", "left image ms (first eye)", "right image ms (reproject + fill)", "total ms",
         "box hierarchy ms (once)"},
        cells);
}

}  // namespace plx::cli
