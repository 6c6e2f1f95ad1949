// parallax stereo SCENE: a stereo pair (or a walkthrough of pairs) with the full or P-buffer
// method, in any of the output layouts, with the second eye's quality against the full method.
// Each pose is timed as a display would run it: one warm-up pair, then --frames timed pairs.

#include <fmt/format.h>

#include <plx/scene/import.h>
#include <plx/stereo/layout.h>
#include <plx/stereo/path.h>
#include <plx/stereo/stereo.h>

#include "commands.h"
#include "view.h"

namespace plx::cli {
namespace {

struct StereoArgs {
    std::string scene;
    ViewArgs view;
    std::string method = "pbuffer";
    bool conservative = false;
    float separation = 0.065f;
    float convergence = 3.0f;
    std::string rig = "toe-in";
    std::string firstEye = "left";
    std::string format = "pair";
    std::string shading = "flat";
    std::string path;
    int walk = 0;
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

Result<StereoPlan> plan(const StereoArgs& a) {
    StereoPlan p;
    auto method = stereo::parseMethod(a.method);
    if (!method) return method.status();
    auto rigType = parseStereoRigType(a.rig);
    if (!rigType) return rigType.status();
    auto layout = stereo::parseLayout(a.format);
    if (!layout) return layout.status();
    auto shading = raster::parseShading(a.shading);
    if (!shading) return shading.status();
    if (a.firstEye != "left" && a.firstEye != "right")
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--first-eye '{}' must be left or right", a.firstEye));
    if (a.walk < 0 || a.walk > 100000)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--walk {} outside 0 .. 100000", a.walk));
    if (a.frames < 1 || a.frames > kMaxFrames)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--frames {} outside 1 .. {}", a.frames, kMaxFrames));
    if (a.walk > 0 && !a.path.empty())
        return errorStatus(ErrorCode::kInvalidArgument, "--walk and --path exclude each other");
    if (auto size = parseSize(a.view.size); !size) return size.status();
    p.options.method = *method;
    p.options.conservative = a.conservative;
    p.options.render.shading = *shading;
    p.rig.type = *rigType;
    p.rig.separation = a.separation;
    p.rig.convergence = a.convergence;
    p.rig.firstEye = a.firstEye == "left" ? Eye::kLeft : Eye::kRight;
    p.layout = *layout;
    // Validate the rig numbers now, with a throwaway camera.
    auto probe = StereoRig::create(*Camera::create({}), p.rig);
    if (!probe) return probe.status();
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
    return std::isfinite(db) ? db : 99.0;
}

// The cameras of a walkthrough: --walk N poses of the built-in walk, or the --path file's.
Result<std::vector<Camera>> walkCameras(const scene::Scene& scene, const StereoArgs& a,
                                        IVec2 size) {
    std::vector<stereo::Pose> poses;
    if (a.walk > 0) {
        poses = stereo::builtinWalk(scene, a.walk);
    } else {
        auto loaded = stereo::loadPath(a.path);
        if (!loaded) return loaded.status();
        poses = std::move(loaded).value();
    }
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
// collection of the visible set, as `parallax bench stereo` counts it.
struct PairTimes {
    double firstMs = 0, secondMs = 0, pairMs = 0;
};

// One untimed warm-up pair (cold caches, the renderer's first allocations), then `frames` timed
// pairs of the same pose; `frame` and `last` keep the last of them.
PairTimes timePairs(stereo::StereoRenderer& renderer, const scene::Scene& scene,
                    const StereoRig& rig, const stereo::StereoOptions& options, int frames,
                    stereo::StereoFrame* frame, stereo::StereoFrameStats* last) {
    renderer.renderPair(scene, rig, options, frame);
    std::vector<double> first, second, pair;
    for (int i = 0; i < frames; ++i) {
        *last = renderer.renderPair(scene, rig, options, frame);
        first.push_back(last->firstEyeMs);
        second.push_back(last->secondEyeMs + last->collectMs);
        pair.push_back(last->pairMs);
    }
    return {median(first), median(second), median(pair)};
}

int runStereo(const StereoArgs& a) {
    auto p = plan(a);
    if (!p) return fail(p.status().message(), kExitUsage);
    auto renderer = stereo::StereoRenderer::create({a.threads});
    if (!renderer) return fail(renderer.status().message(), kExitUsage);
    auto scene = scene::loadScene(a.scene);
    if (!scene) return fail(scene.status());
    if (Status s = ensureParentDirectory(a.out); !s) return fail(s);

    // The poses: one from the camera options, or a walkthrough.
    std::vector<Camera> cameras;
    auto size = *parseSize(a.view.size);
    if (a.walk > 0 || !a.path.empty()) {
        auto walk = walkCameras(*scene, a, size);
        if (!walk) return fail(walk.status());
        cameras = std::move(walk).value();
    } else {
        auto cam = cameraFor(*scene, a.view);
        if (!cam) return fail(cam.status().message(), kExitUsage);
        cameras.push_back(*cam);
    }

    // The timed pairs write colour only, as `parallax bench stereo` times them: the layouts show
    // nothing else. An untimed pair with depth and IDs (the same images) gives the visible set
    // and, against a full pair, the quality. Not with --conservative: its guard band follows the
    // previous frame's depth, so a further pair could differ from the one written; its pairs keep
    // their planes and the last timed one is measured itself.
    const bool colourOnly = !p->options.conservative;
    stereo::StereoFrame frame, withPlanes, reference;
    stereo::StereoOptions timedOptions = p->options;
    timedOptions.writeDepthAndIds = !colourOnly;
    stereo::StereoOptions fullOptions = p->options;
    fullOptions.method = stereo::Method::kFull;
    fullOptions.conservative = false;
    nlohmann::json frames = nlohmann::json::array();
    std::vector<double> firstMs, secondMs, pairMs, psnrs, identical;
    std::vector<std::string> written;
    stereo::StereoFrameStats last;
    stereo::SecondEyeQuality quality;
    Progress progress("stereo poses", cameras.size());
    for (size_t i = 0; i < cameras.size(); ++i) {
        auto rig = StereoRig::create(cameras[i], p->rig);
        if (!rig) return fail(rig.status());
        PairTimes t = timePairs(**renderer, *scene, *rig, timedOptions, a.frames, &frame, &last);
        // Not part of the timings above: the visible set, and the quality against the full
        // method.
        const stereo::StereoFrame* measured = &frame;
        if (colourOnly) {
            last.visibleTriangles =
                (*renderer)->renderPair(*scene, *rig, p->options, &withPlanes).visibleTriangles;
            measured = &withPlanes;
        }
        std::vector<uint32_t> drawn((*renderer)->lastVisibleSet().begin(),
                                    (*renderer)->lastVisibleSet().end());
        Eye second = rig->secondEye();
        if (p->options.method == stereo::Method::kFull) {
            quality = stereo::SecondEyeQuality{INFINITY, 0.0, 0, 0, 0};
        } else {
            (*renderer)->renderPair(*scene, *rig, fullOptions, &reference);
            quality = stereo::compareSecondEye(measured->eye(second), reference.eye(second), drawn);
            if (cameras.size() == 1) {
                std::string diffPath = a.out + ".diff.png";
                if (Status s = writePng(diffPath, diffImage(frame.eye(second).color,
                                                            reference.eye(second).color, 4.0f, 40));
                    !s)
                    return fail(s);
                written.push_back(diffPath);
            }
        }
        std::string prefix = cameras.size() == 1 ? a.out : fmt::format("{}_{:04}", a.out, i);
        if (Status s = writeFrame(frame, p->layout, prefix, &written); !s) return fail(s);
        firstMs.push_back(t.firstMs);
        secondMs.push_back(t.secondMs);
        pairMs.push_back(t.pairMs);
        psnrs.push_back(jsonDb(quality.psnrDb));
        identical.push_back(1.0 - quality.differingFraction);
        frames.push_back({{"pose", i},
                          {"first_eye_ms", t.firstMs},
                          {"second_eye_ms", t.secondMs},
                          {"pair_ms", t.pairMs},
                          {"visible_triangles", last.visibleTriangles},
                          {"second_eye_psnr_db", jsonDb(quality.psnrDb)},
                          {"identical_fraction", identical.back()},
                          {"missed_polygons", quality.missedPolygons}});
        progress.step();
    }
    // Times are medians over a pose's timed pairs; walkthroughs report the median over poses.
    nlohmann::json doc = {
        {"scene", a.scene},
        {"method", stereo::methodName(p->options.method)},
        {"conservative", p->options.conservative},
        {"rig", p->rig.type == StereoRigType::kConverged ? "toe-in" : "parallel"},
        {"separation", p->rig.separation},
        {"convergence", p->rig.convergence},
        {"width", size.x},
        {"height", size.y},
        {"frames", a.frames},
        {"poses", cameras.size()},
        {"triangles", scene->triangleCount()},
        {"visible_triangles", last.visibleTriangles},
        {"second_eye_triangles", last.secondEyeTriangles},
        {"conservative_extra_triangles", last.conservativeExtra},
        {"first_eye_ms", median(firstMs)},
        {"second_eye_ms", median(secondMs)},
        {"pair_ms", median(pairMs)},
        {"second_eye_psnr_db", median(psnrs)},
        {"second_eye_differing_fraction", quality.differingFraction},
        {"identical_fraction", median(identical)},
        {"missed_polygons", quality.missedPolygons},
        {"format", stereo::layoutName(p->layout)},
        {"outputs", cameras.size() == 1 ? nlohmann::json(written) : nlohmann::json(written.size())},
    };
    if (cameras.size() > 1) doc["per_pose"] = frames;
    if (a.json) {
        printJson(doc);
    } else {
        fmt::print("{}: {} triangles, {} visible in the first eye, method {}{}\n", a.scene,
                   scene->triangleCount(), last.visibleTriangles, doc["method"].get<std::string>(),
                   p->options.conservative ? " (conservative)" : "");
        fmt::print(
            "first eye {:.2f} ms, second eye {:.2f} ms, pair {:.2f} ms (median of {} "
            "timed pairs after a warm-up{}); second eye PSNR {:.1f} dB, {:.4f} of its "
            "pixels identical to the full method's\n",
            median(firstMs), median(secondMs), median(pairMs), a.frames,
            cameras.size() > 1 ? fmt::format(", median over {} poses", cameras.size()) : "",
            median(psnrs), median(identical));
        fmt::print("wrote {} file(s) starting {}\n", written.size(), written.front());
    }
    return kExitOk;
}

}  // namespace

Command registerStereo(CLI::App& app) {
    auto a = std::make_shared<StereoArgs>();
    CLI::App* sub =
        app.add_subcommand("stereo",
                           "Render a stereo pair: full pipeline twice, or the second eye from the "
                           "P-buffer's visible polygons");
    sub->footer(
        "Example: parallax stereo office:64 --method pbuffer --format anaglyph "
        "--out out/stereo --json\n         parallax stereo office:16 --walk 60 --out "
        "out/walk/frame");
    sub->add_option("scene", a->scene, "Model file or generator spec (office:N, museum:N)")
        ->required();
    addViewOptions(sub, &a->view);
    sub->add_option("--method", a->method, "full | pbuffer")->capture_default_str();
    sub->add_flag("--conservative", a->conservative,
                  "Widen the visible set (guard band + second depth layer at depth edges)");
    sub->add_option("--separation", a->separation, "Eye separation e (scene units)")
        ->capture_default_str();
    sub->add_option("--convergence", a->convergence, "Convergence distance c (scene units)")
        ->capture_default_str();
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
    sub->add_option("--out", a->out, "Output prefix")->required();
    sub->add_flag("--json", a->json, "Print a JSON result on stdout");
    return {sub, [a] { return runStereo(*a); }};
}

}  // namespace plx::cli
