#include <fmt/format.h>

#include <plx/scene/generators.h>
#include <plx/stereo/experiment.h>

namespace plx::stereo {
namespace {

struct MethodTiming {
    double first = 0, second = 0, collect = 0;
    StereoFrameStats last;
};

// Median timings of `frames` pairs after one warm-up pair.
MethodTiming timeMethod(StereoRenderer& renderer, const scene::Scene& scene, const StereoRig& rig,
                        const StereoOptions& options, int frames, StereoFrame* frame) {
    std::vector<double> first, second, collect;
    MethodTiming t;
    t.last = renderer.renderPair(scene, rig, options, frame);
    for (int f = 0; f < frames; ++f) {
        t.last = renderer.renderPair(scene, rig, options, frame);
        first.push_back(t.last.firstEyeMs);
        second.push_back(t.last.secondEyeMs);
        collect.push_back(t.last.collectMs);
    }
    t.first = median(first);
    t.second = median(second);
    t.collect = median(collect);
    return t;
}

}  // namespace

Result<std::vector<StereoExperimentRow>> runStereoExperiment(
    const StereoExperimentConfig& config, const std::function<void(size_t, size_t)>& progress) {
    if (config.rooms.empty() || config.frames < 1 || config.width < 1 || config.height < 1)
        return errorStatus(ErrorCode::kInvalidArgument, "stereo experiment needs rooms, frames "
                                                         "and a size");
    auto renderer = StereoRenderer::create({config.threads});
    if (!renderer) return renderer.status();
    std::vector<StereoExperimentRow> rows;
    StereoFrame frame, fullFrame;
    for (size_t i = 0; i < config.rooms.size(); ++i) {
        int n = config.rooms[i];
        auto scene = scene::generateOffice(n);
        if (!scene) return scene.status();
        const scene::Viewpoint& vp = scene->viewpoints.front();
        CameraDesc d;
        d.eyePos = vp.eyePos;
        d.targetPos = vp.targetPos;
        d.upDir = vp.upDir;
        d.fovYDegrees = vp.fovYDegrees;
        d.width = config.width;
        d.height = config.height;
        scene::clipPlanesFor(scene->bounds(), vp.eyePos, &d.nearPlane, &d.farPlane);
        auto center = Camera::create(d);
        if (!center) return center.status();
        auto rig = StereoRig::create(*center, config.rig);
        if (!rig) return rig.status();

        StereoOptions options;
        options.render.shading = config.shading;
        options.method = Method::kFull;
        MethodTiming full = timeMethod(**renderer, *scene, *rig, options, config.frames, &fullFrame);
        options.method = Method::kPBuffer;
        MethodTiming pbuf = timeMethod(**renderer, *scene, *rig, options, config.frames, &frame);
        Eye second = rig->secondEye();
        SecondEyeQuality q = compareSecondEye(frame.eye(second), fullFrame.eye(second),
                                              (*renderer)->lastVisibleSet());
        StereoExperimentRow row;
        row.rooms = n;
        row.polygons = scene->triangleCount();
        row.visiblePolygons = pbuf.last.visibleTriangles;
        row.fullFirstMs = full.first;
        row.fullSecondMs = full.second;
        row.pbufferFirstMs = pbuf.first;
        row.pbufferSecondMs = pbuf.second;
        row.collectMs = pbuf.collect;
        row.pairSpeedup = (full.first + full.second) / (pbuf.first + pbuf.collect + pbuf.second);
        row.secondEyePsnrDb = q.psnrDb;
        row.differingFraction = q.differingFraction;
        row.missedPolygons = q.missedPolygons;
        row.missedPixels = q.missedPixels;
        if (config.conservative) {
            options.conservative = true;
            MethodTiming cons = timeMethod(**renderer, *scene, *rig, options, config.frames, &frame);
            SecondEyeQuality cq = compareSecondEye(frame.eye(second), fullFrame.eye(second),
                                                   (*renderer)->lastVisibleSet());
            row.conservativeExtra = cons.last.conservativeExtra;
            row.conservativeFirstMs = cons.first;
            row.conservativeSecondMs = cons.second + cons.collect;
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
double finiteOr(double v, double fallback) { return std::isfinite(v) ? v : fallback; }
}  // namespace

nlohmann::json experimentToJson(const StereoExperimentConfig& config,
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

std::string experimentToCsv(const std::vector<StereoExperimentRow>& rows) {
    std::string csv =
        "rooms,polygons,visible_polygons,full_first_ms,full_second_ms,pbuffer_first_ms,"
        "pbuffer_collect_ms,pbuffer_second_ms,pair_speedup,second_eye_psnr_db,differing_fraction,"
        "missed_polygons,missed_pixels,conservative_extra_polygons,conservative_first_ms,"
        "conservative_second_ms,conservative_psnr_db,conservative_missed_polygons,"
        "conservative_missed_pixels\n";
    for (const auto& r : rows)
        csv += fmt::format("{},{},{},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.2f},{:.6f},{},{},"
                           "{},{:.3f},{:.3f},{:.2f},{},{}\n",
                           r.rooms, r.polygons, r.visiblePolygons, r.fullFirstMs, r.fullSecondMs,
                           r.pbufferFirstMs, r.collectMs, r.pbufferSecondMs, r.pairSpeedup,
                           finiteOr(r.secondEyePsnrDb, 99.0), r.differingFraction,
                           r.missedPolygons, r.missedPixels, r.conservativeExtra,
                           r.conservativeFirstMs, r.conservativeSecondMs,
                           finiteOr(r.conservativePsnrDb, 99.0), r.conservativeMissedPolygons,
                           r.conservativeMissedPixels);
    return csv;
}

}  // namespace plx::stereo
