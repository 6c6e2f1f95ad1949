#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <plx/stereo/path.h>

#include <plx/core/file.h>

namespace plx::stereo {
namespace {

Status readVec3(const nlohmann::json& pose, const char* key, size_t index, bool required,
                Vec3* out) {
    auto it = pose.find(key);
    if (it == pose.end()) {
        if (!required) return Status::ok();
        return errorStatus(ErrorCode::kCorruptData, fmt::format("pose {}: missing \"{}\"", index, key));
    }
    if (!it->is_array() || it->size() != 3)
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("pose {}: \"{}\" must be an array of 3 numbers", index, key));
    for (int i = 0; i < 3; ++i) {
        const auto& v = (*it)[size_t(i)];
        if (!v.is_number() || !std::isfinite(v.get<double>()))
            return errorStatus(ErrorCode::kCorruptData,
                               fmt::format("pose {}: \"{}\"[{}] is not a finite number", index, key, i));
        (*out)[i] = v.get<float>();
    }
    return Status::ok();
}

}  // namespace

Result<std::vector<Pose>> parsePath(const std::string& text) {
    nlohmann::json doc;
    try {
        doc = nlohmann::json::parse(text);
    } catch (const nlohmann::json::parse_error& e) {  // position only: what() quotes the text
        return errorStatus(ErrorCode::kCorruptData, "path is not valid JSON at " +
                                                        lineColumn(text, e.byte ? e.byte - 1 : 0));
    } catch (const nlohmann::json::exception&) {  // a number out of range: no position kept
        return errorStatus(ErrorCode::kCorruptData,
                           "path is not valid JSON (a number out of range)");
    }
    const nlohmann::json* poses = &doc;
    if (doc.is_object()) {
        auto it = doc.find("poses");
        if (it == doc.end())
            return errorStatus(ErrorCode::kCorruptData, "path object has no \"poses\" array");
        poses = &*it;
    }
    if (!poses->is_array()) return errorStatus(ErrorCode::kCorruptData, "\"poses\" is not an array");
    if (poses->empty()) return errorStatus(ErrorCode::kCorruptData, "path has no poses");
    if (poses->size() > kMaxPathPoses)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("path has {} poses, more than {}", poses->size(), kMaxPathPoses));
    std::vector<Pose> out;
    for (size_t i = 0; i < poses->size(); ++i) {
        const auto& p = (*poses)[i];
        if (!p.is_object())
            return errorStatus(ErrorCode::kCorruptData, fmt::format("pose {} is not an object", i));
        Pose pose;
        PLX_RETURN_IF_ERROR(readVec3(p, "eye", i, true, &pose.eyePos));
        PLX_RETURN_IF_ERROR(readVec3(p, "target", i, true, &pose.targetPos));
        PLX_RETURN_IF_ERROR(readVec3(p, "up", i, false, &pose.upDir));
        if (auto fov = p.find("fov"); fov != p.end()) {
            if (!fov->is_number() || !(fov->get<double>() > 0.0 && fov->get<double>() < 180.0))
                return errorStatus(ErrorCode::kCorruptData,
                                   fmt::format("pose {}: \"fov\" must be a number in (0, 180)", i));
            pose.fovYDegrees = fov->get<float>();
        }
        out.push_back(pose);
    }
    return out;
}

Result<std::vector<Pose>> loadPath(const std::string& path) {
    auto bytes = readFileBytes(path);
    if (!bytes) return bytes.status();
    auto poses = parsePath(std::string(bytes->begin(), bytes->end()));
    if (!poses) return errorStatus(poses.status().code(), path + ": " + poses.status().message());
    return poses;
}

std::vector<Pose> builtinWalk(const scene::Scene& scene, int frames) {
    scene::Viewpoint start =
        scene.viewpoints.empty() ? scene::framingViewpoint(scene.bounds()) : scene.viewpoints.front();
    Vec3 forward = start.targetPos - start.eyePos;
    forward.y = 0.0f;
    float len = glm::length(forward);
    forward = len > 1e-6f ? forward / len : Vec3(0.0f, 0.0f, -1.0f);
    Vec3 side = glm::normalize(glm::cross(forward, Vec3(0.0f, 1.0f, 0.0f)));
    // About 1.2 m per second of walking at 30 poses a second, capped at 8 m in total.
    float step = std::min(0.04f, 8.0f / float(std::max(frames, 1)));
    std::vector<Pose> poses;
    for (int i = 0; i < frames; ++i) {
        float t = float(i);
        float sway = 0.3f * std::sin(t * 0.05f);
        float turn = 0.25f * std::sin(t * 0.031f);
        Pose p;
        p.eyePos = start.eyePos + forward * (step * t) + side * sway;
        Vec3 dir = glm::normalize(forward * std::cos(turn) + side * std::sin(turn));
        Vec3 tilt = glm::normalize(start.targetPos - start.eyePos);
        p.targetPos = p.eyePos + dir * 5.0f + Vec3(0.0f, tilt.y * 5.0f, 0.0f);
        p.fovYDegrees = start.fovYDegrees;
        poses.push_back(p);
    }
    return poses;
}

}  // namespace plx::stereo
