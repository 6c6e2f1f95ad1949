#pragma once
// Camera options shared by the commands that render a scene: --size, --eye/--target/--up/--fov,
// --viewpoint. Without --eye the scene's default viewpoint is used, or a camera framing the
// scene's bounds when it has none.

#include <optional>

#include <plx/scene/scene.h>
#include <plx/stereo/path.h>

#include "cli.h"

namespace plx::cli {

struct ViewArgs {
    std::string size = "1280x720";
    std::string eye, target, up = "0,1,0";
    float fovDegrees = 0.0f;  // read only when fovGiven; else the viewpoint's own
    bool fovGiven = false;    // --fov was given (whatever its value, NaN included)
    std::string fovText;      // as given, for errors (1e308 reads as inf)
    std::string viewpoint;    // name or index
};

void addViewOptions(CLI::App* app, ViewArgs* args);

// A scene from a file or generator spec under the input policy (--allow-external-refs,
// --max-pixels); each import warning is printed, or with --strict fails the load.
Result<scene::Scene> loadSceneChecked(const std::string& spec);

// The camera the options describe for this scene; errors name the bad option.
Result<Camera> cameraFor(const scene::Scene& scene, const ViewArgs& args);

// --walk N, when given: N in 1 .. kMaxWalkPoses, else an error naming it.
constexpr int kMaxWalkPoses = 100000;
Status checkWalk(const std::optional<int>& walk);

// The poses of a walkthrough: `walk` poses of the built-in walk through `scene` (not null then)
// when given, else the JSON path file's.
Result<std::vector<stereo::Pose>> walkOrPathPoses(const scene::Scene* scene,
                                                  const std::optional<int>& walk,
                                                  const std::string& pathFile);

}  // namespace plx::cli
