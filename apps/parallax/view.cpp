#include <fmt/format.h>

#include <plx/scene/import.h>

#include "view.h"

namespace plx::cli {

void addViewOptions(CLI::App* app, ViewArgs* args) {
    app->add_option("--size", args->size, "Image size WxH")->capture_default_str();
    app->add_option("--eye", args->eye, "Eye position x,y,z (overrides the viewpoint)");
    app->add_option("--target", args->target, "Point looked at x,y,z (with --eye)");
    app->add_option("--up", args->up, "Up direction x,y,z (with --eye)")->capture_default_str();
    app->add_option("--fov", args->fovDegrees, "Vertical field of view in degrees")
        ->each([args](const std::string& text) {
            args->fovGiven = true;
            args->fovText = text;
        });
    app->add_option("--viewpoint", args->viewpoint, "Scene viewpoint by name or index");
}

Result<scene::Scene> loadSceneChecked(const std::string& spec) {
    scene::ImportOptions options;
    options.allowExternalRefs = inputPolicy().allowExternalRefs;
    options.maxTexturePixels = inputPolicy().maxPixels;
    options.isolation.enabled = inputPolicy().isolate;
    options.isolation.maxMemoryBytes = size_t(inputPolicy().importMemoryMb) << 20;
    options.isolation.maxSeconds = inputPolicy().importSeconds;
    auto scene = scene::loadScene(spec, options);
    if (!scene) return scene.status();
    for (const std::string& w : scene->warnings) PLX_RETURN_IF_ERROR(warn(spec + ": " + w));
    return scene;
}

Result<Camera> cameraFor(const scene::Scene& scene, const ViewArgs& args) {
    auto size = parseSize(args.size);
    if (!size) return size.status();
    scene::Viewpoint vp;
    if (args.eye.empty() && !args.target.empty())
        return errorStatus(ErrorCode::kInvalidArgument, "--target needs --eye");
    // A given value must be a usable angle, whatever it is (0 and NaN included).
    if (args.fovGiven && !(args.fovDegrees > 0.0f && args.fovDegrees < 180.0f))
        return errorStatus(
            ErrorCode::kInvalidArgument,
            fmt::format("--fov {} must lie strictly between 0 and 180 degrees", args.fovText));
    if (!args.eye.empty()) {
        auto eye = parseVec3(args.eye);
        if (!eye)
            return errorStatus(ErrorCode::kInvalidArgument, "--eye: " + eye.status().message());
        if (args.target.empty())
            return errorStatus(ErrorCode::kInvalidArgument, "--eye needs --target");
        auto target = parseVec3(args.target);
        if (!target)
            return errorStatus(ErrorCode::kInvalidArgument,
                               "--target: " + target.status().message());
        auto up = parseVec3(args.up);
        if (!up) return errorStatus(ErrorCode::kInvalidArgument, "--up: " + up.status().message());
        vp.name = "command line";
        vp.eyePos = *eye;
        vp.targetPos = *target;
        vp.upDir = *up;
    } else {
        auto picked = scene::findViewpoint(scene, args.viewpoint);
        if (!picked) return picked.status();
        vp = *picked;
    }
    if (args.fovGiven) vp.fovYDegrees = args.fovDegrees;
    auto cam = scene::cameraAt(scene, vp, size->x, size->y);
    if (!cam) return cam.status();
    return cam;
}

Status checkWalk(const std::optional<int>& walk) {
    if (walk && (*walk < 1 || *walk > kMaxWalkPoses))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("--walk {} outside 1 .. {}", *walk, kMaxWalkPoses));
    return Status::ok();
}

Result<std::vector<stereo::Pose>> walkOrPathPoses(const scene::Scene* scene,
                                                  const std::optional<int>& walk,
                                                  const std::string& pathFile) {
    if (walk) return stereo::builtinWalk(*scene, *walk);
    return stereo::loadPath(pathFile);
}

}  // namespace plx::cli
