#include <fmt/format.h>

#include <plx/core/stereo_rig.h>

namespace plx {

Result<StereoRig> StereoRig::create(const Camera& center, const StereoRigDesc& desc) {
    if (!enumWithin(desc.type, StereoRigType::kConverged, StereoRigType::kParallel) ||
        !enumWithin(desc.firstEye, Eye::kLeft, Eye::kRight))
        return errorStatus(ErrorCode::kInvalidArgument, "unknown stereo rig type or first eye");
    if (!(desc.separation >= 0.0f) || !std::isfinite(desc.separation))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("eye separation {} must be a finite number >= 0",
                                       desc.separation));
    bool converged = desc.type == StereoRigType::kConverged;
    if (converged && (!(desc.convergence > 0.0f) || !std::isfinite(desc.convergence)))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("convergence distance {} must be a finite number > 0",
                                       desc.convergence));
    const CameraDesc& c = center.desc();
    float focalPx = 0.5f * float(c.height) / std::tan(0.5f * radians(c.fovYDegrees));
    float shiftPx = converged ? desc.separation * focalPx / (2.0f * desc.convergence) : 0.0f;
    auto makeEye = [&](float side) {
        CameraDesc d = c;
        Vec3 offset = center.rightDir() * (side * 0.5f * desc.separation);
        d.eyePos = c.eyePos + offset;
        d.targetPos = c.targetPos + offset;  // sight lines stay parallel to the centre's
        d.upDir = center.upDir();
        // Seen from this eye a point at distance c straight ahead lies -side * e/2 off axis and
        // projects -side * shift pixels from the centre; panning by +side * shift cancels that.
        d.principalShiftPx.x = c.principalShiftPx.x + side * shiftPx;
        return Camera::create(d);
    };
    // A valid centre with an eye it cannot hold (too far out) is the separation's doing.
    auto eyeError = [&](const char* eye, const Status& s) {
        return errorStatus(s.code(), fmt::format("eye separation {} puts the {} eye out of range: "
                                                 "{}",
                                                 desc.separation, eye, s.message()));
    };
    auto left = makeEye(-1.0f);
    if (!left) return eyeError("left", left.status());
    auto right = makeEye(1.0f);
    if (!right) return eyeError("right", right.status());
    return StereoRig(desc, std::move(left).value(), std::move(right).value(), focalPx, shiftPx);
}

float StereoRig::disparityPx(float depthZ) const {
    float e = mDesc.separation;
    if (mDesc.type == StereoRigType::kParallel) return -e * mFocalPx / depthZ;
    return e * mFocalPx * (1.0f / mDesc.convergence - 1.0f / depthZ);
}

Result<StereoRigType> parseStereoRigType(const std::string& name) {
    if (name == "converged" || name == "toe-in") return StereoRigType::kConverged;
    if (name == "parallel") return StereoRigType::kParallel;
    return errorStatus(ErrorCode::kInvalidArgument,
                       fmt::format("unknown stereo rig '{}' (toe-in, converged, parallel)", name));
}

}  // namespace plx
