// Reference views and sets (reference.h): the cube and wide layouts around a pose, rendered with
// raster::Renderer, and each row's disparity range for the row clip (clip.h).

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <utility>

#include <fmt/format.h>

#include <plx/core/timing.h>
#include <plx/warp/reference.h>

#include "row_kernel.h"

namespace plx::warp {

Result<ReferenceLayout> parseReferenceLayout(const std::string& name) {
    if (name == "cube4") return ReferenceLayout::kCube4;
    if (name == "cube6") return ReferenceLayout::kCube6;
    if (name == "wide") return ReferenceLayout::kWide;
    return errorStatus(ErrorCode::kInvalidArgument,
                       "unknown reference layout '" + name + "' (cube4, cube6, wide)");
}

int referenceViewCount(ReferenceLayout layout) {
    return layout == ReferenceLayout::kCube6 ? 6 : layout == ReferenceLayout::kWide ? 1 : 4;
}

const char* referenceLayoutName(ReferenceLayout layout) {
    switch (layout) {
        case ReferenceLayout::kCube4:
            return "cube4";
        case ReferenceLayout::kCube6:
            return "cube6";
        case ReferenceLayout::kWide:
            return "wide";
    }
    return "?";
}

Status checkPose(const Pose& pose) {
    if (!isFinite(pose.eye)) return {ErrorCode::kInvalidArgument, "pose: eye is not finite"};
    if (!isFinite(pose.forward) || !isFinite(pose.up))
        return {ErrorCode::kInvalidArgument, "pose: forward or up is not finite"};
    const float f = glm::length(pose.forward);
    const float u = glm::length(pose.up);
    if (!(f > 1e-6f) || !(u > 1e-6f))
        return {ErrorCode::kInvalidArgument, "pose: forward or up has zero length"};
    // sin of the angle between them; below ~0.06 degrees the frame is numerically meaningless.
    if (!(glm::length(glm::cross(pose.forward / f, pose.up / u)) > 1e-3f))
        return {ErrorCode::kInvalidArgument, "pose: up is parallel to forward"};
    return {};
}

Status checkReferenceSetOptions(const ReferenceSetOptions& o) {
    if (!enumWithin(o.layout, ReferenceLayout::kCube4, ReferenceLayout::kWide))
        return {ErrorCode::kInvalidArgument, "unknown reference layout"};
    if (o.faceSize < 1 || o.faceSize > Camera::kMaxImageSide)
        return {ErrorCode::kInvalidArgument, "reference face size " + std::to_string(o.faceSize) +
                                                 " outside 1.." +
                                                 std::to_string(Camera::kMaxImageSide)};
    if (!(o.wideFovDegrees > 0.0f && o.wideFovDegrees < 180.0f))
        return {
            ErrorCode::kInvalidArgument,
            "wide field of view " + std::to_string(o.wideFovDegrees) + " degrees outside (0, 180)"};
    // The aspect shapes the wide view alone; a cube face is square whatever it holds.
    if (o.layout == ReferenceLayout::kWide) {
        if (!(o.wideAspect > 0.0f) || !std::isfinite(o.wideAspect))
            return {ErrorCode::kInvalidArgument,
                    fmt::format("wide aspect {} is not a positive number", o.wideAspect)};
        const double width = std::round(double(o.faceSize) * o.wideAspect);
        if (width > Camera::kMaxImageSide)
            return {ErrorCode::kInvalidArgument,
                    fmt::format("a wide view of {} rows at aspect {:g} would be {:.0f} pixels "
                                "wide, above {}",
                                o.faceSize, o.wideAspect, width, Camera::kMaxImageSide)};
    }
    if (!(o.nearPlane > 0.0f && o.nearPlane < o.farPlane) || !std::isfinite(o.farPlane))
        return {ErrorCode::kInvalidArgument, "reference near/far planes need 0 < near < far"};
    return {};
}

Result<std::vector<Camera>> referenceCameras(const Pose& pose, const ReferenceSetOptions& o) {
    PLX_RETURN_IF_ERROR(checkPose(pose));
    PLX_RETURN_IF_ERROR(checkReferenceSetOptions(o));
    const Vec3 fwd = glm::normalize(pose.forward);
    const Vec3 right = glm::normalize(glm::cross(fwd, pose.up));
    const Vec3 up = glm::cross(right, fwd);
    struct Face {
        Vec3 dir, up;
    };
    // A layout's views are the first referenceViewCount of these: the wide view looks forward,
    // cube4 adds the sides and the back, cube6 up and down.
    const Face faces[] = {{fwd, up}, {right, up}, {-fwd, up}, {-right, up}, {up, -fwd}, {-up, fwd}};
    std::vector<Camera> cameras;
    for (const Face& face : std::span(faces).first(size_t(referenceViewCount(o.layout)))) {
        CameraDesc d;
        d.eyePos = pose.eye;
        d.targetPos = targetAlong(pose.eye, face.dir);
        d.upDir = face.up;
        d.nearPlane = o.nearPlane;
        d.farPlane = o.farPlane;
        if (o.layout == ReferenceLayout::kWide) {
            d.fovYDegrees = o.wideFovDegrees;
            d.height = o.faceSize;
            d.width = int(std::lround(double(o.faceSize) * o.wideAspect));
        } else {
            d.fovYDegrees = 90.0f;
            d.width = d.height = o.faceSize;
        }
        Result<Camera> camera = Camera::create(d);
        if (!camera) return camera.status();
        cameras.push_back(std::move(camera).value());
    }
    return cameras;
}

Pose poseAt(const scene::Viewpoint& viewpoint) {
    Pose pose;
    pose.eye = viewpoint.eyePos;
    pose.forward = glm::normalize(viewpoint.targetPos - viewpoint.eyePos);
    pose.up = viewpoint.upDir;
    return pose;
}

namespace {

// The float of an ordered key: its bit pattern made an integer that orders as the float does
// (negative values' magnitude bits flipped; -0 just below +0; row_range.inl), so that min and
// max reductions are integer ones, which vectorise where IEEE rules forbid the compiler the float
// ones (std::minmax_element took 15% of a server's CPU time at 1248-pixel faces).
float fromOrderedKey(int32_t k) {
    return std::bit_cast<float>(k ^ int32_t(uint32_t(k >> 31) >> 1));
}

// The smallest and largest value of a row without NaN.
std::pair<float, float> rowMinMax(const float* row, int width) {
    const detail::KeyRange k = detail::activeRowKeyRange()(row, width);
    return {fromOrderedKey(k.lo), fromOrderedKey(k.hi)};
}

}  // namespace

void computeRowDisparityRange(ReferenceView* view) {
    const Image<float>& disparity = view->disparity;
    view->rowMinDisparity.assign(size_t(disparity.height()), 0.0f);
    view->rowMaxDisparity.assign(size_t(disparity.height()), 0.0f);
    if (disparity.width() == 0) return;
    for (int y = 0; y < disparity.height(); ++y) {
        const auto [lo, hi] = rowMinMax(disparity.row(y), disparity.width());
        view->rowMinDisparity[size_t(y)] = lo;
        view->rowMaxDisparity[size_t(y)] = hi;
    }
}

Status renderReferenceSet(raster::Renderer& renderer, const scene::Scene& scene, const Pose& pose,
                          const ReferenceSetOptions& options, ReferenceSet* out) {
    Result<std::vector<Camera>> cameras = referenceCameras(pose, options);
    if (!cameras) return cameras.status();
    Stopwatch timer;
    out->pose = pose;
    out->views.resize(cameras->size());
    raster::RenderOptions render = options.render;
    // The warp reads depth; a colour-only render would leave it unwritten.
    render.colorOnly = false;
    render.clearTargets = true;
    render.clearDrawnTilesOnly = false;
    for (size_t v = 0; v < cameras->size(); ++v) {
        ReferenceView& view = out->views[v];
        view.camera = (*cameras)[v];
        // The render clears every pixel (clearTargets, all tiles): buffers of the right size
        // from the set before are reused without filling them first (a server renders into the
        // same set for every session frame).
        const int w = view.camera.width(), h = view.camera.height();
        if (view.color.width() != w || view.color.height() != h) view.color.resize(w, h);
        if (view.disparity.width() != w || view.disparity.height() != h)
            view.disparity.resize(w, h);
        raster::RenderTargets targets{view.color.view(), view.disparity.view(), {}, {}};
        renderer.render(scene, view.camera, render, targets);
        computeRowDisparityRange(&view);
    }
    out->renderMs = timer.elapsedMs();
    return {};
}

}  // namespace plx::warp
