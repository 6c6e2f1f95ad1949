#pragma once
// Pinhole camera: position, orientation from eye/target/up, vertical field of view, near/far
// planes and image size. Follows the Conventions block in <plx/core/core.h>: right-handed world,
// camera looks down -z in its own space, OpenGL clip space (-w <= x,y,z <= w).

#include <algorithm>
#include <string>

#include <plx/core/math.h>
#include <plx/core/status.h>

namespace plx {

// The largest eye, target or scene coordinate a camera takes (Camera::create): lengths square the
// coordinates, and beyond 1e18 they overflow a float; 1e15 leaves room for differences and
// products. Scenes refuse vertices beyond it (scene::Scene::finalize).
inline constexpr float kMaxCameraCoordinate = 1e15f;

// True where a coordinate of v lies beyond +-kMaxCameraCoordinate.
inline bool beyondCameraRange(const Vec3& v) {
    return glm::any(glm::greaterThan(glm::abs(v), Vec3(kMaxCameraCoordinate)));
}

// A target that looks from `eye` along the unit vector `dir`, far enough that eye and target
// differ in float far from the origin (at 1e8 a unit step is lost to rounding): at least one
// unit, and as far as the eye's largest coordinate.
inline Vec3 targetAlong(const Vec3& eye, const Vec3& dir) {
    const Vec3 a = glm::abs(eye);
    return eye + dir * std::max(1.0f, std::max(a.x, std::max(a.y, a.z)));
}

struct CameraDesc {
    Vec3 eyePos{0.0f, 0.0f, 5.0f};
    Vec3 targetPos{0.0f, 0.0f, 0.0f};
    Vec3 upDir{0.0f, 1.0f, 0.0f};
    float fovYDegrees = 60.0f;
    float nearPlane = 0.05f;
    float farPlane = 1000.0f;
    int width = 1280;
    int height = 720;
    // Shift of the principal point from the image centre, in pixels (+x right, +y down). Off-axis
    // projections (stereo image shift) use it; 0 for an ordinary centred camera.
    Vec2 principalShiftPx{0.0f, 0.0f};
};

class Camera {
public:
    // Validates the description: finite vectors, eye != target, up not parallel to the view
    // direction, 0 < fov < 180, 0 < near < far, 1 <= width, height <= kMaxImageSide.
    static Result<Camera> create(const CameraDesc& desc);

    static constexpr int kMaxImageSide = 16384;

    const CameraDesc& desc() const { return mDesc; }
    int width() const { return mDesc.width; }
    int height() const { return mDesc.height; }
    Vec3 eyePos() const { return mDesc.eyePos; }
    // Unit vectors of the camera frame in world space.
    Vec3 forwardDir() const { return mForward; }
    Vec3 rightDir() const { return mRight; }
    Vec3 upDir() const { return mUp; }

    const Mat4& viewFromWorld() const { return mViewFromWorld; }
    const Mat4& clipFromView() const { return mClipFromView; }
    const Mat4& clipFromWorld() const { return mClipFromWorld; }

    // Pixel position (x right, y down, pixel centres at +0.5) of a clip-space point after the
    // perspective divide. Precondition: clip.w > 0.
    Vec2 pixelFromClip(const Vec4& clip) const {
        float invW = 1.0f / clip.w;
        return {(clip.x * invW * 0.5f + 0.5f) * float(mDesc.width),
                (0.5f - clip.y * invW * 0.5f) * float(mDesc.height)};
    }
    // Pixel position of a world point; returns false when it lies behind the eye.
    bool projectToPixel(const Vec3& worldPos, Vec2* pixel) const;

private:
    explicit Camera(const CameraDesc& desc);
    CameraDesc mDesc;
    Vec3 mForward, mRight, mUp;
    Mat4 mViewFromWorld, mClipFromView, mClipFromWorld;
};

// Parses an image size "WxH" (e.g. "1280x720"); errors name the text and the accepted range
// 1x1 .. kMaxImageSide x kMaxImageSide.
Result<IVec2> parseImageSize(const std::string& text);

}  // namespace plx
