#pragma once
// Camera paths for stereo walkthroughs: a JSON list of poses, or a built-in path through an
// office:N scene.
//
// JSON form: {"poses": [{"eye": [x,y,z], "target": [x,y,z], "up": [x,y,z]?, "fov": deg?}, ...]}
// or a bare array of such poses.

#include <string>
#include <vector>

#include <plx/scene/scene.h>

namespace plx::stereo {

struct Pose {
    Vec3 eyePos{0.0f};
    Vec3 targetPos{0.0f, 0.0f, -1.0f};
    Vec3 upDir{0.0f, 1.0f, 0.0f};
    float fovYDegrees = 60.0f;
};

// Parses a path; errors name the pose and field. At most kMaxPathPoses poses.
constexpr size_t kMaxPathPoses = 100000;
Result<std::vector<Pose>> parsePath(const std::string& jsonText);
Result<std::vector<Pose>> loadPath(const std::string& path);

// A walk of `frames` poses from the scene's default viewpoint: forward along its view direction
// with a gentle sideways sway and head turn, staying at eye height (office scenes).
std::vector<Pose> builtinWalk(const scene::Scene& scene, int frames);

}  // namespace plx::stereo
