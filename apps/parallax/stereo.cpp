// parallax stereo SCENE: a stereo pair (or a walkthrough of pairs) with the full, P-buffer or
// reproject method, in any of the output layouts, with the second eye's quality against the full
// method.
// Each pose is timed as a display would run it: one warm-up pair, then --frames timed pairs.

#include <fmt/format.h>

#include <plx/scene/import.h>
#include <plx/stereo/layout.h>
#include <plx/stereo/path.h>
#include <plx/stereo/stereo.h>

#include "commands.h"
#include "hole_classes.h"
#include "view.h"

namespace plx::cli {
namespace {

struct StereoArgs {
    std::string scene;
    ViewArgs view;
    std::string method = "pbuffer";
    bool conservative = false;
    bool reprojectLut = false;
    bool surroundingFirst = false;
    std::string fillSearch;  // empty: not given (boxes)
    float separation = 0.065f;
    float convergence = 3.0f;
    std::string rig = "toe-in";
    std::string firstEye = "left";
    std::string format = "pair";
    std::string shading = "flat";
    std::string path;
    std::optional<int> walk;
    int threads = 0;
    int frames = 9;
    std::string out;
    bool json = false;
};

// More timed pairs than this per pose is a typo, not a measurement.
constexpr int kMaxFrames = 10000;

// Everything parsed from the options before any work starts (usage errors exit with 2).
struct StereoPlan {
    stereo::StereoOptions options;
    StereoRigDesc rig;
    stereo::Layout layout = stereo::Layout::kPair;
};

// Bytes per scene triangle of the method's search structures: the reproject method's, else 0.
double stereoBytesPerTriangle(const StereoPlan& p) {
    if (p.options.method != stereo::Method::kReproject) return 0.0;
    return p.options.fillSearch == stereo::FillSearch::kBspOrder ? kReprojectBspBytesPerTriangle
                                                                 : kReprojectBoxesBytesPerTriangle;
}

// Peak bytes per image pixel beyond the scene (checkImageMemory). The growth of the peak from
// 1024x1024 to 2048x2048 (office:2): full 36.3, pbuffer 52.2 (--conservative 69.5), reproject
// 69.0; a side-by-side or top-bottom image 12-16 more, an anaglyph 4. Rounded up;
// MemoryCli.EstimatesHoldTheMeasuredPeak holds them to the measured peak.
double stereoBytesPerPixel(const StereoPlan& p) {
    double bytes = 0.0;
    switch (p.options.method) {
        case stereo::Method::kFull:
            bytes = 38.0;
            break;
        case stereo::Method::kPBuffer:
            bytes = p.options.conservative ? 73.0 : 55.0;
            break;
        case stereo::Method::kReproject:
            bytes = 72.0;
            break;
    }
    switch (p.layout) {
        case stereo::Layout::kPair:
            return bytes;
        case stereo::Layout::kSideBySide:
        case stereo::Layout::kTopBottom:
            return bytes + 16.0;
        case stereo::Layout::kAnaglyph:
        case stereo::Layout::kInterleaved:
            return bytes + 5.0;
    }
    return bytes;
}

Result<StereoPlan> plan(const StereoArgs& a) {
    StereoPlan p;
    auto method = stereo::parseMethod(a.method);
    if (!method) return method.status();
    // The conservative set widens what the pbuffer method draws; the reproject method draws
    // from no set (its holes are filled by a search of the scene).
    if (a.conservative && *method != stereo::Method::kPBuffer)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--conservative applies to --method pbuffer, not {}",
                                       stereo::methodName(*method)));
    if (a.reprojectLut && *method != stereo::Method::kReproject)
        return errorStatus(ErrorCode::kInvalidArgument,
                           "--reproject-lut applies to --method reproject only");
    if (a.surroundingFirst && *method != stereo::Method::kReproject)
        return errorStatus(ErrorCode::kInvalidArgument,
                           "--surrounding-first applies to --method reproject only");
    if (!a.fillSearch.empty() && *method != stereo::Method::kReproject)
        return errorStatus(ErrorCode::kInvalidArgument,
                           "--fill-search applies to --method reproject only");
    auto fillSearch = stereo::parseFillSearch(a.fillSearch.empty() ? "boxes" : a.fillSearch);
    if (!fillSearch) return fillSearch.status();
    auto rigType = parseStereoRigType(a.rig);
    if (!rigType) return rigType.status();
    auto layout = stereo::parseLayout(a.format);
    if (!layout) return layout.status();
    auto shading = raster::parseShading(a.shading);
    if (!shading) return shading.status();
    if (a.firstEye != "left" && a.firstEye != "right")
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--first-eye '{}' must be left or right", a.firstEye));
    PLX_RETURN_IF_ERROR(checkWalk(a.walk));
    if (a.frames < 1 || a.frames > kMaxFrames)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--frames {} outside 1 .. {}", a.frames, kMaxFrames));
    if (a.walk && !a.path.empty())
        return errorStatus(ErrorCode::kInvalidArgument, "--walk and --path exclude each other");
    if (auto size = parseSize(a.view.size); !size) return size.status();
    p.options.method = *method;
    p.options.conservative = a.conservative;
    p.options.reprojectWithLut = a.reprojectLut;
    p.options.reprojectSurroundingFirst = a.surroundingFirst;
    p.options.fillSearch = *fillSearch;
    p.options.render.shading = *shading;
    p.rig.type = *rigType;
    p.rig.separation = a.separation;
    p.rig.convergence = a.convergence;
    p.rig.firstEye = a.firstEye == "left" ? Eye::kLeft : Eye::kRight;
    p.layout = *layout;
    PLX_RETURN_IF_ERROR(checkStereoRigNumbers(p.rig));
    return p;
}

Status writeFrame(const stereo::StereoFrame& frame, stereo::Layout layout,
                  const std::string& prefix, std::vector<std::string>* written) {
    if (layout == stereo::Layout::kPair) {
        PLX_RETURN_IF_ERROR(writePng(prefix + ".left.png", frame.left.color));
        PLX_RETURN_IF_ERROR(writePng(prefix + ".right.png", frame.right.color));
        written->push_back(prefix + ".left.png");
        written->push_back(prefix + ".right.png");
        return Status::ok();
    }
    std::string path = prefix + "." + stereo::layoutName(layout) + ".png";
    PLX_RETURN_IF_ERROR(
        writePng(path, stereo::composeStereo(frame.left.color, frame.right.color, layout)));
    written->push_back(path);
    return Status::ok();
}

double jsonDb(double db) {
    return std::isfinite(db) ? db : kIdenticalPsnrDb;
}

// The cameras of a walkthrough: --walk N poses of the built-in walk, or the --path file's.
Result<std::vector<Camera>> walkCameras(const scene::Scene& scene, const StereoArgs& a,
                                        IVec2 size) {
    auto loaded = walkOrPathPoses(&scene, a.walk, a.path);
    if (!loaded) return loaded.status();
    const std::vector<stereo::Pose> poses = std::move(loaded).value();
    std::vector<Camera> cameras;
    for (size_t i = 0; i < poses.size(); ++i) {
        scene::Viewpoint vp{"path", poses[i].eyePos, poses[i].targetPos, poses[i].upDir,
                            poses[i].fovYDegrees};
        auto cam = scene::cameraAt(scene, vp, size.x, size.y);
        if (!cam)
            return errorStatus(cam.status().code(),
                               fmt::format("pose {}: {}", i, cam.status().message()));
        cameras.push_back(*cam);
    }
    return cameras;
}

// Medians over the timed pairs of one pose. The second eye includes the pbuffer method's
// collection of the visible set, as `parallax bench stereo` counts it; the reproject method's is
// reprojectMs + fillMs.
struct PairTimes {
    double firstMs = 0, secondMs = 0, pairMs = 0, reprojectMs = 0, fillMs = 0;
};

// One untimed warm-up pair (cold caches, the renderer's first allocations), then `frames` timed
// pairs of the same pose; `frame` and `last` keep the last of them.
PairTimes timePairs(stereo::StereoRenderer& renderer, const scene::Scene& scene,
                    const StereoRig& rig, const stereo::StereoOptions& options, int frames,
                    stereo::StereoFrame* frame, stereo::StereoFrameStats* last) {
    renderer.renderPair(scene, rig, options, frame);
    std::vector<double> first, second, pair, reproject, fill;
    for (int i = 0; i < frames; ++i) {
        *last = renderer.renderPair(scene, rig, options, frame);
        first.push_back(last->firstEyeMs);
        second.push_back(last->secondEyeMs + last->collectMs);
        pair.push_back(last->pairMs);
        reproject.push_back(last->reprojectMs);
        fill.push_back(last->fillMs);
    }
    return {median(first), median(second), median(pair), median(reproject), median(fill)};
}

// The renderer, scene and frames that every pose of one run reuses.
struct StereoSession {
    stereo::StereoRenderer& renderer;
    const scene::Scene& scene;
    const StereoPlan& plan;
    int frames = 1;
    stereo::StereoFrame frame, withPlanes;
    raster::FrameBuffers reference;  // the full method's second eye (its first eye is not needed)
};

// One pose: its timings, the last timed pair's statistics and the second eye's quality.
struct PoseResult {
    PairTimes times;
    stereo::StereoFrameStats stats;
    stereo::SecondEyeQuality quality{INFINITY, 0.0, 0, 0, 0};
};

// Times the pose into s.frame, then, untimed, measures the visible set and the second eye
// against the full method's. The timed pairs write colour only, as `parallax bench stereo` times
// them: the layouts show nothing else. An untimed pair with depth and IDs (the same images) gives
// the visible set and the quality. Not with --conservative: its guard band follows the previous
// frame's depth, so a further pair could differ from the one written; its pairs keep their
// planes and the last timed one is measured itself.
PoseResult runPose(StereoSession& s, const StereoRig& rig) {
    const stereo::StereoOptions& options = s.plan.options;
    const bool colourOnly = !options.conservative;
    stereo::StereoOptions timed = options;
    timed.writeDepthAndIds = !colourOnly;
    PoseResult r;
    r.times = timePairs(s.renderer, s.scene, rig, timed, s.frames, &s.frame, &r.stats);
    const stereo::StereoFrame* measured = &s.frame;
    if (colourOnly) {
        r.stats.visibleTriangles =
            s.renderer.renderPair(s.scene, rig, options, &s.withPlanes).visibleTriangles;
        measured = &s.withPlanes;
    }
    // The reproject method collects no visible set; count the first eye's IDs instead.
    if (options.method == stereo::Method::kReproject)
        r.stats.visibleTriangles = raster::countDistinctIds(measured->eye(rig.desc().firstEye).id);
    if (options.method == stereo::Method::kFull) return r;
    Eye second = rig.secondEye();
    std::vector<uint32_t> drawn = drawnSet(s.renderer, options.method, measured->eye(second));
    renderFullSecondEye(s.renderer, s.scene, rig, options.render, &s.reference);
    r.quality = stereo::compareSecondEye(measured->eye(second), s.reference, drawn);
    return r;
}

// The second eye's difference from the full method (x4, magenta above 40); for the reproject
// method its hole classes instead (kHoleClassLegend). After runPose.
Image<Rgba8> secondEyeDiff(const StereoSession& s, Eye second) {
    const Image<Rgba8>& colour = s.frame.eye(second).color;
    const Image<uint8_t>& classes =
        s.withPlanes.holeClass.empty() ? s.frame.holeClass : s.withPlanes.holeClass;
    if (s.plan.options.method == stereo::Method::kReproject && !classes.empty())
        return holeClassImage(colour, classes);
    return diffImage(colour, s.reference.color, 4.0f, 40);
}

// The reproject method's counts (zero for the other methods).
nlohmann::json holeJson(const stereo::StereoFrameStats& st, int pixels) {
    return {{"hole_pixels", st.holePixels},
            {"hole_fraction", double(st.holePixels) / double(std::max(1, pixels))},
            {"expansion_pixels", st.expansionPixels},
            {"disocclusion_pixels", st.disocclusionPixels},
            {"expansion_holes", st.expansionHoles},
            {"disocclusion_holes", st.disocclusionHoles},
            {"fill_nodes_visited", st.fillNodesVisited},
            {"fill_polygons_tested", st.fillPolygonsTested},
            {"fill_polygons_drawn", st.fillPolygonsDrawn},
            {"unseen_pixels", st.unseenPixels},
            {"unseen_triangles", st.unseenTriangles}};
}

// Medians over poses of each pose's values.
struct PoseMedians {
    std::vector<double> first, second, pair, reproject, fill, psnr, identical;

    void add(const PoseResult& r) {
        first.push_back(r.times.firstMs);
        second.push_back(r.times.secondMs);
        pair.push_back(r.times.pairMs);
        reproject.push_back(r.times.reprojectMs);
        fill.push_back(r.times.fillMs);
        psnr.push_back(jsonDb(r.quality.psnrDb));
        identical.push_back(1.0 - r.quality.differingFraction);
    }
};

nlohmann::json poseJson(size_t index, const PoseResult& r, int pixels) {
    nlohmann::json j = {{"pose", index},
                        {"first_eye_ms", r.times.firstMs},
                        {"second_eye_ms", r.times.secondMs},
                        {"pair_ms", r.times.pairMs},
                        {"reproject_ms", r.times.reprojectMs},
                        {"fill_ms", r.times.fillMs},
                        {"visible_triangles", r.stats.visibleTriangles},
                        {"second_eye_psnr_db", jsonDb(r.quality.psnrDb)},
                        {"identical_fraction", 1.0 - r.quality.differingFraction},
                        {"missed_polygons", r.quality.missedPolygons}};
    j.update(holeJson(r.stats, pixels));
    return j;
}

void printText(const StereoArgs& a, const nlohmann::json& doc, size_t poses,
               const std::vector<std::string>& written) {
    fmt::print("{}: {} triangles, {} visible in the first eye, method {}{}\n", a.scene,
               doc["triangles"].get<size_t>(), doc["visible_triangles"].get<size_t>(),
               doc["method"].get<std::string>(), a.conservative ? " (conservative)" : "");
    fmt::print(
        "first eye {:.2f} ms, second eye {:.2f} ms, pair {:.2f} ms (median of {} timed "
        "pair{} after a warm-up{}); second eye PSNR {:.1f} dB, {:.4f} of its pixels "
        "identical to the full method's\n",
        doc["first_eye_ms"].get<double>(), doc["second_eye_ms"].get<double>(),
        doc["pair_ms"].get<double>(), a.frames, a.frames == 1 ? "" : "s",
        poses > 1 ? fmt::format(", median over {} poses", poses) : "",
        doc["second_eye_psnr_db"].get<double>(), doc["identical_fraction"].get<double>());
    if (doc["method"] == "reproject")
        fmt::print(
            "second eye: reproject {:.2f} ms + fill {:.2f} ms; {} hole pixels in {} "
            "expansion and {} disocclusion holes; prepared in {:.1f} ms\n",
            doc["reproject_ms"].get<double>(), doc["fill_ms"].get<double>(),
            doc["hole_pixels"].get<int64_t>(), doc["expansion_holes"].get<size_t>(),
            doc["disocclusion_holes"].get<size_t>(), doc["prepare_ms"].get<double>());
    fmt::print("wrote {} starting {}\n", counted(written.size(), "file"), written.front());
}

// The cameras of the run: one from the camera options (usage errors), or a walkthrough's.
Result<std::vector<Camera>> camerasFor(const scene::Scene& scene, const StereoArgs& a, IVec2 size,
                                       int* errorExit) {
    *errorExit = kExitFailure;
    if (a.walk || !a.path.empty()) return walkCameras(scene, a, size);
    *errorExit = kExitUsage;
    auto cam = cameraFor(scene, a.view);
    if (!cam) return cam.status();
    return std::vector<Camera>{*cam};
}

int runStereo(const StereoArgs& a) {
    auto p = plan(a);
    if (!p) return fail(p.status().message(), kExitUsage);
    auto renderer = stereo::StereoRenderer::create({a.threads});
    if (!renderer) return fail(renderer.status().message(), kExitUsage);
    auto scene = loadSceneChecked(a.scene);
    if (!scene) return fail(scene.status());
    if (Status s = ensureParentDirectory(a.out); !s) return fail(s);
    const IVec2 size = *parseSize(a.view.size);
    int errorExit = kExitFailure;
    auto cameras = camerasFor(*scene, a, size, &errorExit);
    if (!cameras) return fail(cameras.status().message(), errorExit);
    // Before the reproject method's search structures are built: their memory grows with the
    // scene (about 0.1 GB at 1M triangles, 0.3 GB with the BSP tree).
    const double searchBytes = stereoBytesPerTriangle(*p) * double(scene->triangleCount());
    std::string what = fmt::format("stereo --method {}", stereo::methodName(p->options.method));
    if (searchBytes > 0.0)
        what += fmt::format(" --fill-search {}", stereo::fillSearchName(p->options.fillSearch));
    what += fmt::format(" at {}x{}", size.x, size.y);
    if (searchBytes > 0.0) what += fmt::format(" on {} triangles", scene->triangleCount());
    auto memory = checkImageMemory(
        what, stereoBytesPerPixel(*p) * double(size.x) * double(size.y) + searchBytes,
        scene->triangleCount());
    if (!memory) return fail(memory.status());
    // What the reproject method's search walks (box hierarchy; BSP tree for --fill-search bsp),
    // built once before any timing.
    double prepareMs = 0.0;
    if (p->options.method == stereo::Method::kReproject) {
        if (Status s = (*renderer)->prepareReprojection(*scene, p->options.fillSearch); !s)
            return fail(s);
        prepareMs = (*renderer)->lastPrepareMs();
    }

    StereoSession session{**renderer, *scene, *p, a.frames, {}, {}, {}};
    const bool single = cameras->size() == 1;
    const int pixels = size.x * size.y;
    nlohmann::json perPose = nlohmann::json::array();
    PoseMedians m;
    PoseResult last;
    std::vector<std::string> written;
    Progress progress("stereo poses", cameras->size());
    for (size_t i = 0; i < cameras->size(); ++i) {
        auto rig = StereoRig::create((*cameras)[i], p->rig);
        if (!rig) return fail(rig.status());
        last = runPose(session, *rig);
        if (last.stats.visibleTriangles == 0)  // only blank images could follow, and a perfect score
            return fail(
                fmt::format("pose {}: the first eye sees none of the scene (check "
                            "--separation, --convergence, --eye, --target)",
                            i));
        if (single && p->options.method != stereo::Method::kFull) {
            std::string diffPath = a.out + ".diff.png";
            if (Status s = writePng(diffPath, secondEyeDiff(session, rig->secondEye())); !s)
                return fail(s);
            written.push_back(diffPath);
        }
        std::string prefix = single ? a.out : fmt::format("{}_{:04}", a.out, i);
        if (Status s = writeFrame(session.frame, p->layout, prefix, &written); !s) return fail(s);
        m.add(last);
        perPose.push_back(poseJson(i, last, pixels));
        progress.step();
    }
    // Times are medians over a pose's timed pairs; walkthroughs report the median over poses of
    // the times and the quality (the two fractions add up to 1), and the last pose's counts.
    nlohmann::json doc = {
        {"scene", a.scene},
        {"method", stereo::methodName(p->options.method)},
        {"conservative", p->options.conservative},
        {"reproject_lut", p->options.reprojectWithLut},
        {"surrounding_first", p->options.reprojectSurroundingFirst},
        {"fill_search", stereo::fillSearchName(p->options.fillSearch)},
        {"rig", p->rig.type == StereoRigType::kConverged ? "toe-in" : "parallel"},
        {"separation", shortestDecimal(p->rig.separation)},
        {"convergence", shortestDecimal(p->rig.convergence)},
        {"width", size.x},
        {"height", size.y},
        {"frames", a.frames},
        {"poses", cameras->size()},
        {"triangles", scene->triangleCount()},
        {"visible_triangles", last.stats.visibleTriangles},
        {"second_eye_triangles", last.stats.secondEyeTriangles},
        {"conservative_extra_triangles", last.stats.conservativeExtra},
        {"prepare_ms", prepareMs},
        {"first_eye_ms", median(m.first)},
        {"second_eye_ms", median(m.second)},
        {"pair_ms", median(m.pair)},
        {"reproject_ms", median(m.reproject)},
        {"fill_ms", median(m.fill)},
        {"second_eye_psnr_db", median(m.psnr)},
        {"second_eye_differing_fraction", 1.0 - median(m.identical)},
        {"identical_fraction", median(m.identical)},
        {"missed_polygons", last.quality.missedPolygons},
        {"format", stereo::layoutName(p->layout)},
        {"outputs", written},
    };
    doc.update(holeJson(last.stats, pixels));
    doc.update(memoryJson(*memory));
    if (!single) doc["per_pose"] = perPose;
    if (a.json)
        printJson(doc);
    else
        printText(a, doc, cameras->size(), written);
    return kExitOk;
}

}  // namespace

Command registerStereo(CLI::App& app) {
    auto a = std::make_shared<StereoArgs>();
    CLI::App* sub =
        app.add_subcommand("stereo",
                           "Render a stereo pair: full pipeline twice, the second eye from the "
                           "P-buffer's visible polygons, or reprojected from the first eye");
    sub->footer(
        std::string("Example: parallax stereo office:64 --method pbuffer --format anaglyph "
                    "--out out/stereo --json\n"
                    "         parallax stereo office:64 --method reproject --frames 9 "
                    "--out out/reproject --json\n"
                    "         parallax stereo office:16 --walk 60 --frames 1 --out out/walk/frame\n"
                    "PREFIX.diff.png (one pose): the second eye against the full method's "
                    "(x4, magenta above 40); reproject: ") +
        kHoleClassLegend);
    sub->add_option("scene", a->scene, "Model file or generator spec (office:N, museum:N)")
        ->required();
    addViewOptions(sub, &a->view);
    sub->add_option("--method", a->method,
                    "full | pbuffer | reproject (second eye moved from the first, holes filled)")
        ->capture_default_str();
    sub->add_flag(
        "--conservative", a->conservative,
        "pbuffer: widen the visible set (guard band + second depth layer at depth edges)");
    sub->add_flag("--reproject-lut", a->reprojectLut,
                  "reproject: offsets from a look-up table over depth (Fu, Bao, Peng) instead of "
                  "the multiply-add per pixel (the offset is linear in 1/w)");
    sub->add_flag("--surrounding-first", a->surroundingFirst,
                  "reproject: fill disocclusion holes from the polygons around them first, "
                  "searching only what they leave open (faster, approximate)");
    sub->add_option("--fill-search", a->fillSearch,
                    "reproject: boxes (box hierarchy, nearest box first; default) | bsp (the "
                    "paper's front-to-back BSP walk; builds the BSP tree first)");
    sub->add_option("--separation", a->separation, "Eye separation e (scene units)")
        ->capture_default_str()
        ->check(floatNumber());
    sub->add_option("--convergence", a->convergence, "Convergence distance c (scene units)")
        ->capture_default_str()
        ->check(floatNumber());
    sub->add_option("--rig", a->rig, "toe-in (converged by the image shift of eq. 1) | parallel")
        ->capture_default_str();
    sub->add_option("--first-eye", a->firstEye, "left | right: the eye rendered first")
        ->capture_default_str();
    sub->add_option("--format", a->format, "pair | sbs | tb | anaglyph | interleaved")
        ->capture_default_str();
    sub->add_option("--shading", a->shading, "flat | gouraud | textured")->capture_default_str();
    sub->add_option("--path", a->path, "Walkthrough: a JSON list of poses");
    sub->add_option("--walk", a->walk, "Walkthrough: N poses of the built-in walk");
    sub->add_option("--threads", a->threads, "Worker threads (0: all cores)");
    sub->add_option("--frames", a->frames,
                    "Timed pairs per pose after one untimed warm-up pair; times are their medians")
        ->capture_default_str();
    sub->add_option("--out", a->out, "Output prefix")
        ->required()
        ->check(outputPath(OutputKind::kPrefix));
    sub->add_flag("--json", a->json, "Print a JSON result on stdout");
    return {sub, [a] { return runStereo(*a); }};
}

}  // namespace plx::cli
