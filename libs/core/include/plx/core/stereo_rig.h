#pragma once
// Stereo camera rigs (Heo, Jung, Wohn, section III.1).
//
// Converged rig: the two-centres-of-projection model of eq. (1). Both eyes look along the centre
// camera's direction from positions offset by -e/2 (left) and +e/2 (right) along its right axis,
// and each image is panned horizontally by e*f/(2c) so that points at the convergence distance c
// have zero disparity:
//     x_left  = f (x + e/2) / Z - e f / (2c),   x_right = f (x - e/2) / Z + e f / (2c),
//     y_left  = y_right = f y / Z              (no vertical parallax)
// with x measured from the centre camera, Z the depth along the view direction and f the
// projection distance in pixels, (height / 2) / tan(fovY / 2). (The paper writes the eye offsets
// with the opposite sign of x; the geometry is the same.) The CLI also accepts "toe-in" for this
// rig: it converges like toed-in cameras but by the image shift, so it has no vertical parallax.
//
// Parallel rig: the same eye offsets with no image shift (convergence at infinity), as used by
// the reprojection method of Fu, Bao and Peng.

#include <plx/core/camera.h>

namespace plx {

enum class StereoRigType { kConverged, kParallel };
enum class Eye { kLeft, kRight };

struct StereoRigDesc {
    StereoRigType type = StereoRigType::kConverged;
    float separation = 0.065f;   // e, scene units (metres): a typical interocular distance
    float convergence = 3.0f;    // c, scene units; the converged rig's zero-disparity distance
    Eye firstEye = Eye::kLeft;   // the eye rendered first (the one the P-buffer is taken from)
};

class StereoRig {
public:
    // Builds the two eye cameras from a centre camera. Errors: separation negative or not finite,
    // convergence <= 0 or not finite (converged rig), a type or first eye outside its enum.
    static Result<StereoRig> create(const Camera& center, const StereoRigDesc& desc);

    const StereoRigDesc& desc() const { return mDesc; }
    const Camera& left() const { return mLeft; }
    const Camera& right() const { return mRight; }
    const Camera& eye(Eye e) const { return e == Eye::kLeft ? mLeft : mRight; }
    const Camera& first() const { return eye(mDesc.firstEye); }
    const Camera& second() const { return eye(mDesc.firstEye == Eye::kLeft ? Eye::kRight : Eye::kLeft); }
    Eye secondEye() const { return mDesc.firstEye == Eye::kLeft ? Eye::kRight : Eye::kLeft; }

    // f of eq. (1) in pixels.
    float projectionDistancePx() const { return mFocalPx; }
    // The horizontal pan e f / (2c) in pixels (0 for the parallel rig); the left image moves
    // by -shift, the right by +shift.
    float imageShiftPx() const { return mShiftPx; }
    // Horizontal disparity x_right - x_left in pixels of a point at depth Z (eq. 1):
    // e f (1/c - 1/Z) for the converged rig, -e f / Z for the parallel rig.
    float disparityPx(float depthZ) const;

private:
    StereoRig(const StereoRigDesc& desc, Camera left, Camera right, float focalPx, float shiftPx)
        : mDesc(desc), mLeft(std::move(left)), mRight(std::move(right)), mFocalPx(focalPx),
          mShiftPx(shiftPx) {}
    StereoRigDesc mDesc;
    Camera mLeft, mRight;
    float mFocalPx = 0.0f, mShiftPx = 0.0f;
};

Result<StereoRigType> parseStereoRigType(const std::string& name);

}  // namespace plx
