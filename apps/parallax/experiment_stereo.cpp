// The experiment of Heo, Jung, Wohn (Table 1, Fig. 17): full pipeline against the P-buffer
// method on office:N, timed pair by pair.

#include "experiment_stereo.h"

#include <cmath>

#include <fmt/format.h>

#include <plx/scene/generators.h>

#include "report.h"

namespace plx::cli {

namespace {

struct MethodTiming {
    std::vector<double> first, second, collect;
    stereo::StereoFrameStats last;
    std::vector<uint32_t> drawn;  // the set the quality frame drew (pbuffer methods)

    void add(const stereo::StereoFrameStats& st) {
        last = st;
        first.push_back(st.firstEyeMs);
        second.push_back(st.secondEyeMs);
        collect.push_back(st.collectMs);
    }
};

// Times the methods frame by frame in turn after one warm-up pair each, so that load from other
// processes falls on all of them alike. The order rotates every frame (full, pbuffer,
// conservative; then pbuffer, conservative, full; ...): a method's first eye finds the caches
// as the method before it left them (a full pass over the scene, or a small subset), and a
// fixed order gave the method after the full one a first eye up to 0.5 ms slower at 1M
// triangles, with the same renderer and the same scene.
// The timed frames write colour only (StereoOptions::writeDepthAndIds): what a display shows,
// and neither method then pays for 2.5 MB of depth and IDs per eye that nobody reads.
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
        (*timings)[m].drawn.assign(renderer.lastVisibleSet().begin(),
                                   renderer.lastVisibleSet().end());
    }
}

}  // namespace

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
        int n = config.rooms[i];
        auto scene = scene::generateOffice(n);
        if (!scene) return scene.status();
        auto center =
            scene::cameraAt(*scene, scene::defaultViewpoint(*scene), config.width, config.height);
        if (!center) return center.status();
        auto rig = StereoRig::create(*center, config.rig);
        if (!rig) return rig.status();

        std::vector<stereo::StereoOptions> options(config.conservative ? 3 : 2);
        for (auto& o : options) o.render.shading = config.shading;
        options[0].method = stereo::Method::kFull;
        options[1].method = stereo::Method::kPBuffer;
        if (config.conservative) {
            options[2].method = stereo::Method::kPBuffer;
            options[2].conservative = true;
        }
        std::vector<stereo::StereoFrame> frames(options.size());
        std::vector<MethodTiming> t;
        timeMethods(**renderer, *scene, *rig, options, config.frames, &frames, &t);
        renderForQuality(**renderer, *scene, *rig, options, &frames, &t);
        Eye second = rig->secondEye();
        const stereo::StereoFrame& fullFrame = frames[0];
        stereo::SecondEyeQuality q =
            stereo::compareSecondEye(frames[1].eye(second), fullFrame.eye(second), t[1].drawn);
        StereoExperimentRow row;
        row.rooms = n;
        row.polygons = scene->triangleCount();
        row.visiblePolygons = t[1].last.visibleTriangles;
        row.fullFirstMs = median(t[0].first);
        row.fullSecondMs = median(t[0].second);
        row.pbufferFirstMs = median(t[1].first);
        row.pbufferSecondMs = median(t[1].second);
        row.collectMs = median(t[1].collect);
        row.pairSpeedup = (row.fullFirstMs + row.fullSecondMs) /
                          (row.pbufferFirstMs + row.collectMs + row.pbufferSecondMs);
        row.secondEyePsnrDb = q.psnrDb;
        row.differingFraction = q.differingFraction;
        row.missedPolygons = q.missedPolygons;
        row.missedPixels = q.missedPixels;
        if (config.conservative) {
            stereo::SecondEyeQuality cq =
                stereo::compareSecondEye(frames[2].eye(second), fullFrame.eye(second), t[2].drawn);
            row.conservativeExtra = t[2].last.conservativeExtra;
            row.conservativeFirstMs = median(t[2].first);
            row.conservativeSecondMs = median(t[2].second) + median(t[2].collect);
            row.conservativePsnrDb = cq.psnrDb;
            row.conservativeMissedPolygons = cq.missedPolygons;
            row.conservativeMissedPixels = cq.missedPixels;
        }
        rows.push_back(row);
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
                          {"separation", config.rig.separation},
                          {"convergence", config.rig.convergence},
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
                               {"conservative_missed_pixels", r.conservativeMissedPixels}});
    }
    return out;
}

std::string stereoExperimentCsv(const std::vector<StereoExperimentRow>& rows) {
    std::string csv =
        "rooms,polygons,visible_polygons,full_first_ms,full_second_ms,pbuffer_first_ms,"
        "pbuffer_collect_ms,pbuffer_second_ms,pair_speedup,second_eye_psnr_db,differing_fraction,"
        "missed_polygons,missed_pixels,conservative_extra_polygons,conservative_first_ms,"
        "conservative_second_ms,conservative_psnr_db,conservative_missed_polygons,"
        "conservative_missed_pixels\n";
    for (const auto& r : rows)
        csv += fmt::format(
            "{},{},{},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.2f},{:.6f},{},{},"
            "{},{:.3f},{:.3f},{:.2f},{},{}\n",
            r.rooms, r.polygons, r.visiblePolygons, r.fullFirstMs, r.fullSecondMs, r.pbufferFirstMs,
            r.collectMs, r.pbufferSecondMs, r.pairSpeedup, finiteOr(r.secondEyePsnrDb, 99.0),
            r.differingFraction, r.missedPolygons, r.missedPixels, r.conservativeExtra,
            r.conservativeFirstMs, r.conservativeSecondMs, finiteOr(r.conservativePsnrDb, 99.0),
            r.conservativeMissedPolygons, r.conservativeMissedPixels);
    return csv;
}

std::vector<std::pair<std::string, std::string>> stereoPlots(
    const std::vector<StereoExperimentRow>& rows) {
    PlotSeries fullFirst{"full pipeline", {}}, pbufFirst{"p-buffer method", {}};
    PlotSeries fullSecond{"full pipeline", {}}, pbufSecond{"p-buffer method", {}};
    PlotSeries fullPair{"full pipeline", {}}, pbufPair{"p-buffer method", {}};
    PlotSeries speedup{"pair speedup (full / p-buffer)", {}}, visible{"visible polygons", {}};
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
    }
    auto spec = [](const char* title, const char* y) {
        return PlotSpec{title, "polygons (log scale)", y, true, true};
    };
    return {
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

}  // namespace plx::cli
