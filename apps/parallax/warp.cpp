// parallax warp SCENE: reference images rendered at one pose and warped to a second (Mark,
// Bishop, McMillan's post-rendering warp), against the render at the second pose.

#include <fmt/format.h>

#include <plx/raster/raster.h>
#include <plx/scene/import.h>
#include <plx/warp/reference.h>
#include <plx/warp/warp.h>

#include "commands.h"
#include "experiment_warp.h"
#include "view.h"

namespace plx::cli {
namespace {

struct WarpArgs {
    std::string scene;
    ViewArgs view;
    std::string toEye, toTarget;
    std::string refs = "cube4";
    std::string splat = "derivative";
    int frames = 9;
    int threads = 0;
    std::string out;
    bool json = false;
};

// Everything parsed from the options before any work starts (usage errors exit with 2).
struct WarpPlan {
    warp::ReferenceLayout layout = warp::ReferenceLayout::kCube4;
    warp::WarpOptions options;
    Vec3 toEye{0.0f};
    std::optional<Vec3> toTarget;
};

Result<WarpPlan> plan(const WarpArgs& a) {
    WarpPlan p;
    auto layout = warp::parseReferenceLayout(a.refs);
    if (!layout) return layout.status();
    p.layout = *layout;
    auto splat = warp::parseSplat(a.splat);
    if (!splat) return splat.status();
    p.options.splat = *splat;
    if (a.frames < 1 || a.frames > 100000)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--frames {} outside 1 .. 100000", a.frames));
    if (auto size = parseSize(a.view.size); !size) return size.status();
    auto toEye = parseVec3(a.toEye);
    if (!toEye)
        return errorStatus(ErrorCode::kInvalidArgument, "--to-eye: " + toEye.status().message());
    p.toEye = *toEye;
    if (!a.toTarget.empty()) {
        auto toTarget = parseVec3(a.toTarget);
        if (!toTarget)
            return errorStatus(ErrorCode::kInvalidArgument,
                               "--to-target: " + toTarget.status().message());
        p.toTarget = *toTarget;
    }
    return p;
}

// Peak bytes beyond the scene (checkImageMemory): per reference pixel (the reference set, and
// with mesh splats its meshes) and per display pixel (the warped frame, the render it is held
// against, the PNGs' images). Fitted to the peaks of cube4, cube6 and wide sets at 1024 and 2048
// pixels a side, square and not (office:2): 8.0 per reference pixel (10.3 with mesh splats) and
// 56-59 per display pixel. Rounded up; MemoryCli.EstimatesHoldTheMeasuredPeak holds them to the
// measured peak.
double warpImageBytes(const WarpPlan& p, int64_t referencePixels, const Camera& display) {
    const double perReferencePixel = p.options.splat == warp::Splat::kMesh ? 11.0 : 8.5;
    constexpr double kPerDisplayPixel = 62.0;
    return kPerDisplayPixel * double(display.width()) * double(display.height()) +
           perReferencePixel * double(referencePixels);
}

// The destination camera: the first camera's lens and size at the second pose.
Result<Camera> destinationCamera(const Camera& from, const WarpPlan& p) {
    CameraDesc d = from.desc();
    d.eyePos = p.toEye;
    d.targetPos = p.toTarget.value_or(from.desc().targetPos);
    auto cam = Camera::create(d);
    if (!cam)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--to-eye {},{},{}: {}", d.eyePos.x, d.eyePos.y, d.eyePos.z,
                                       cam.status().message()));
    return cam;
}

// The warped frame against the truth (x4, magenta over 40), with the holes painted over it:
// red where no reference covered the pixel and nothing filled it, blue where the rear-surface
// fill guessed it.
Image<Rgba8> holeDiffImage(const warp::WarpFrame& warped, const Image<Rgba8>& truth) {
    Image<Rgba8> diff = diffImage(warped.color, truth, 4.0f, 40);
    for (int y = 0; y < diff.height(); ++y)
        for (int x = 0; x < diff.width(); ++x) {
            uint8_t m = warped.holeMask.at(x, y);
            if (m == 1) diff.at(x, y) = {255, 0, 0, 255};
            if (m == 2) diff.at(x, y) = {40, 110, 255, 255};
        }
    return diff;
}

int runWarp(const WarpArgs& a) {
    auto p = plan(a);
    if (!p) return fail(p.status().message(), kExitUsage);
    auto renderer = raster::Renderer::create({a.threads});
    if (!renderer) return fail(renderer.status().message(), kExitUsage);
    auto warper = warp::Warper::create(a.threads);
    if (!warper) return fail(warper.status().message(), kExitUsage);
    auto scene = loadSceneChecked(a.scene);
    if (!scene) return fail(scene.status());
    auto from = cameraFor(*scene, a.view);
    if (!from) return fail(from.status().message(), kExitUsage);
    auto to = destinationCamera(*from, *p);
    if (!to) return fail(to.status().message(), kExitUsage);
    if (Status s = ensureParentDirectory(a.out); !s) return fail(s);

    warp::ReferenceSetOptions refOptions = referenceOptionsFor(*scene, *from, p->layout);
    // The faces match the display's pixel density up to the largest image side; past it they
    // undersample it, and a field of view narrow enough leaves the frame all holes (0.0001
    // degrees: 16384-pixel faces, 8 GiB, hole fraction 1).
    if (refOptions.faceSize >= Camera::kMaxImageSide)
        return fail(fmt::format("a {:g}-degree field of view over {} rows needs reference faces "
                                "over {} pixels a side to match its pixels; a wider --fov or "
                                "a smaller --size",
                                from->desc().fovYDegrees, from->height(), Camera::kMaxImageSide),
                    kExitUsage);
    auto setPixels = referencePixels(refOptions);
    if (!setPixels) return fail(setPixels.status());
    auto memory = checkImageMemory(
        fmt::format("warp --refs {} at {}x{}", warp::referenceLayoutName(p->layout), to->width(),
                    to->height()),
        warpImageBytes(*p, *setPixels, *to), scene->triangleCount());
    if (!memory) return fail(memory.status());
    warp::ReferenceSet set;
    if (Status s = warp::renderReferenceSet(**renderer, *scene, poseOf(*from), refOptions, &set);
        !s)
        return fail(s);
    // One warm-up warp, then the timed ones.
    warp::WarpFrame frame;
    warp::WarpStats stats;
    std::vector<double> ms;
    Progress progress("warping", size_t(a.frames));
    for (int f = -1; f < a.frames; ++f) {
        Stopwatch clock;
        if (Status s = (*warper)->warp(set, *to, p->options, &frame, &stats); !s) return fail(s);
        if (f >= 0) ms.push_back(clock.elapsedMs()), progress.step();
    }
    raster::FrameBuffers truth;
    truth.resize(to->width(), to->height());
    (*renderer)->render(*scene, *to, {}, truth.targets());

    const double warpMs = median(ms);
    const double pixels = double(to->width()) * double(to->height());
    const double psnrDb = std::min(psnr(frame.color, truth.color), 99.0);
    const int64_t sourcePixels = referencePixels(set);
    const double mpix = warpMs > 0.0 ? double(sourcePixels) / (warpMs * 1e3) : 0.0;
    std::vector<std::string> written = {a.out + "-warped.png", a.out + "-truth.png",
                                        a.out + "-diff.png"};
    if (Status s = writePng(written[0], frame.color); !s) return fail(s);
    if (Status s = writePng(written[1], truth.color); !s) return fail(s);
    if (Status s = writePng(written[2], holeDiffImage(frame, truth.color)); !s) return fail(s);

    if (a.json) {
        nlohmann::json doc = {{"scene", a.scene},
                              {"refs", warp::referenceLayoutName(p->layout)},
                              {"splat", warp::splatName(p->options.splat)},
                              {"size", fmt::format("{}x{}", to->width(), to->height())},
                              {"face_size", refOptions.faceSize},
                              {"views", set.views.size()},
                              {"frames", a.frames},
                              {"threads", (*warper)->threadCount()},
                              {"reference_render_ms", set.renderMs},
                              {"warp_ms", warpMs},
                              {"mpix_per_s", mpix},
                              {"source_pixels", sourcePixels},
                              {"warped_pixels", stats.sourcePixels},
                              {"rows_total", stats.rowsTotal},
                              {"rows_clipped", stats.rowsSkipped + stats.rowsCut},
                              {"rows_skipped", stats.rowsSkipped},
                              {"rows_cut", stats.rowsCut},
                              {"hole_fraction", double(stats.holePixels) / pixels},
                              {"hole_fraction_left", double(stats.holePixelsLeft) / pixels},
                              {"psnr_db", psnrDb},
                              {"outputs", written}};
        doc.update(memoryJson(*memory));
        printJson(doc);
    } else {
        fmt::print("{}: {} references ({} views of {} px) warped to {}x{} with {} splats\n",
                   a.scene, warp::referenceLayoutName(p->layout), set.views.size(),
                   refOptions.faceSize, to->width(), to->height(),
                   warp::splatName(p->options.splat));
        fmt::print(
            "warp {:.2f} ms (median of {}), {:.1f} source Mpix/s; {} of {} rows "
            "clipped; holes {:.3f}% before the fill; PSNR {:.1f} dB against the render\n",
            warpMs, a.frames, mpix, stats.rowsSkipped + stats.rowsCut, stats.rowsTotal,
            100.0 * double(stats.holePixels) / pixels, psnrDb);
        fmt::print("wrote {}, {}, {}\n", written[0], written[1], written[2]);
    }
    return kExitOk;
}

}  // namespace

Command registerWarp(CLI::App& app) {
    auto a = std::make_shared<WarpArgs>();
    CLI::App* sub = app.add_subcommand(
        "warp", "Warp reference images rendered at one pose to another (post-rendering warp)");
    sub->footer(
        "Example: parallax warp office:8 --to-eye 1.3,1.6,1.1 --refs cube4 --splat "
        "derivative --size 640x480 --out out/warp --json\n"
        "Writes PREFIX-warped.png, PREFIX-truth.png (the render at the second pose) and "
        "PREFIX-diff.png (difference x4, magenta > 40; holes red, filled holes blue).\n"
        "JSON: warp_ms is the median warp, mpix_per_s the reference pixels per second (all "
        "of them; warped_pixels: those left after row clipping), hole_fraction the destination "
        "pixels no reference covered "
        "before the fill, psnr_db the warped frame against the render (99: identical).");
    sub->add_option("scene", a->scene, "Model file or generator spec (office:N, museum:N)")
        ->required();
    addViewOptions(sub, &a->view);
    sub->add_option("--to-eye", a->toEye, "Second pose's eye x,y,z (the warp's destination)")
        ->required();
    sub->add_option("--to-target", a->toTarget,
                    "Second pose's target x,y,z (default: the first pose's target)");
    sub->add_option("--refs", a->refs, "cube4 | cube6 | wide: the reference views")
        ->capture_default_str();
    sub->add_option("--splat", a->splat, "derivative | point | fixed | mesh")
        ->capture_default_str();
    sub->add_option("--frames", a->frames, "Timed warps (median), after one warm-up")
        ->capture_default_str();
    sub->add_option("--threads", a->threads, "Worker threads (0: all cores)");
    sub->add_option("--out", a->out, "Output prefix")
        ->required()
        ->check(outputPath(OutputKind::kPrefix));
    sub->add_flag("--json", a->json, "Print a JSON result on stdout");
    return {sub, [a] { return runWarp(*a); }};
}

}  // namespace plx::cli
