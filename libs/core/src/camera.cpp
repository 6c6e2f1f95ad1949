#include <plx/core/camera.h>

#include <charconv>

#include <fmt/format.h>

namespace plx {

Result<Camera> Camera::create(const CameraDesc& d) {
    if (!isFinite(d.eyePos) || !isFinite(d.targetPos) || !isFinite(d.upDir))
        return errorStatus(ErrorCode::kInvalidArgument, "camera vectors must be finite");
    // Beyond kMaxCameraCoordinate the checks below would blame the up vector.
    for (auto [name, v] : {std::pair{"eye", d.eyePos}, std::pair{"target", d.targetPos},
                           std::pair{"up vector", d.upDir}})
        if (beyondCameraRange(v))
            return errorStatus(ErrorCode::kOutOfRange,
                               fmt::format("camera {} ({:g}, {:g}, {:g}) is too far from the "
                                           "origin: coordinates must lie within +-{:g}",
                                           name, v.x, v.y, v.z, kMaxCameraCoordinate));
    Vec3 forward = d.targetPos - d.eyePos;
    if (glm::length(forward) <= 1e-12f)
        return errorStatus(ErrorCode::kInvalidArgument, "camera eye and target coincide");
    if (glm::length(d.upDir) <= 1e-12f ||
        glm::length(glm::cross(glm::normalize(forward), glm::normalize(d.upDir))) < 1e-6f)
        return errorStatus(ErrorCode::kInvalidArgument,
                           "camera up vector is zero or parallel to the view direction");
    if (!(d.fovYDegrees > 0.0f && d.fovYDegrees < 180.0f))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("field of view {} must lie in (0, 180) degrees",
                                       d.fovYDegrees));
    if (!(d.nearPlane > 0.0f && d.farPlane > d.nearPlane && std::isfinite(d.farPlane)))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("clip planes need 0 < near < far (got near {}, far {})",
                                       d.nearPlane, d.farPlane));
    if (d.width < 1 || d.height < 1 || d.width > kMaxImageSide || d.height > kMaxImageSide)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("image size {}x{} outside 1x1 .. {}x{}", d.width,
                                       d.height, kMaxImageSide, kMaxImageSide));
    if (!std::isfinite(d.principalShiftPx.x) || !std::isfinite(d.principalShiftPx.y))
        return errorStatus(ErrorCode::kInvalidArgument, "principal point shift must be finite");
    return Camera(d);
}

Camera::Camera(const CameraDesc& d) : mDesc(d) {
    mForward = glm::normalize(d.targetPos - d.eyePos);
    mRight = glm::normalize(glm::cross(mForward, d.upDir));
    mUp = glm::cross(mRight, mForward);
    mViewFromWorld = glm::lookAt(d.eyePos, d.targetPos, mUp);
    float aspect = float(d.width) / float(d.height);
    mClipFromView = glm::perspective(radians(d.fovYDegrees), aspect, d.nearPlane, d.farPlane);
    // Principal point shift: moving the image centre by s pixels is x_ndc += 2 s / width, which
    // in clip space is x += (2 s / width) * w with w = -z_view (column 2 holds z's coefficients).
    mClipFromView[2][0] -= 2.0f * d.principalShiftPx.x / float(d.width);
    mClipFromView[2][1] += 2.0f * d.principalShiftPx.y / float(d.height);
    mClipFromWorld = mClipFromView * mViewFromWorld;
}

bool Camera::projectToPixel(const Vec3& worldPos, Vec2* pixel) const {
    Vec4 clip = mClipFromWorld * Vec4(worldPos, 1.0f);
    if (clip.w <= 0.0f) return false;
    *pixel = pixelFromClip(clip);
    return true;
}

Result<IVec2> parseImageSize(const std::string& text) {
    size_t x = text.find_first_of("xX");
    auto bad = [&] {
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("size '{}' is not of the form WxH (e.g. 1280x720)", text));
    };
    if (x == std::string::npos) return bad();
    long long w = 0, h = 0;
    auto r1 = std::from_chars(text.data(), text.data() + x, w);
    auto r2 = std::from_chars(text.data() + x + 1, text.data() + text.size(), h);
    if (r1.ec != std::errc() || r1.ptr != text.data() + x || r2.ec != std::errc() ||
        r2.ptr != text.data() + text.size())
        return bad();
    if (w < 1 || h < 1 || w > Camera::kMaxImageSide || h > Camera::kMaxImageSide)
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("size {} outside 1x1 .. {}x{}", text, Camera::kMaxImageSide,
                                       Camera::kMaxImageSide));
    return IVec2(int(w), int(h));
}

}  // namespace plx
