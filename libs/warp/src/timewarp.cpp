// Rotation-only timewarp: the peer the post-rendering warp is measured against (Mark, Bishop,
// McMillan, "Prediction techniques": what a system without depth can do for head rotation).
//
// Every point is taken as infinitely far, so a pixel moves by the homography of the rotation
// alone, H = K2 R2^T R1 K1^-1 (reference pixel to destination pixel; R = camera-to-world basis,
// K = pixel-from-camera intrinsics). The image is inverse-mapped: each destination pixel centre
// goes through H^-1 = K1 R1^T R2 K2^-1 and the reference colour is sampled there bilinearly
// (on the sRGB bytes, as a display's timewarp filter does). A destination pixel whose source
// lies behind the reference camera or outside its image gets the clear colour. The translation
// between the cameras is ignored: that is the error the warp with disparity removes.

#include <cmath>

#include <fmt/format.h>

#include <plx/warp/warp.h>

namespace plx::warp {

namespace {

using DMat3 = glm::dmat3;
using DVec3 = glm::dvec3;

// Pixel-from-camera intrinsics of a Camera (camera axes right, up, forward; pixels y down;
// pixel centres at +0.5). Square pixels: the focal length in pixels is H / (2 tan(fovY / 2)).
DMat3 pixelFromCamera(const Camera& cam) {
    const CameraDesc& d = cam.desc();
    double f = double(d.height) / (2.0 * std::tan(double(radians(d.fovYDegrees)) * 0.5));
    double cx = 0.5 * double(d.width) + double(d.principalShiftPx.x);
    double cy = 0.5 * double(d.height) + double(d.principalShiftPx.y);
    // glm is column-major: DMat3(col0, col1, col2).
    return DMat3(DVec3(f, 0.0, 0.0), DVec3(0.0, -f, 0.0), DVec3(cx, cy, 1.0));
}

// World-from-camera rotation: columns are the camera's right, up and forward axes.
DMat3 worldFromCamera(const Camera& cam) {
    return DMat3(DVec3(cam.rightDir()), DVec3(cam.upDir()), DVec3(cam.forwardDir()));
}

Rgba8 lerp(Rgba8 a, Rgba8 b, float t) {
    auto mix = [t](uint8_t u, uint8_t v) {
        return uint8_t(std::lround(float(u) + (float(v) - float(u)) * t));
    };
    return {mix(a.r, b.r), mix(a.g, b.g), mix(a.b, b.b), mix(a.a, b.a)};
}

// Bilinear sample at continuous pixel coordinates (u, v) (pixel centres at +0.5), inside
// [0, W] x [0, H]; the half pixel at each border clamps to the edge pixels.
Rgba8 sampleBilinear(const Image<Rgba8>& img, double u, double v) {
    const int w = img.width(), h = img.height();
    double fx = u - 0.5, fy = v - 0.5;
    int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
    float tx = float(fx - x0), ty = float(fy - y0);
    int xa = std::clamp(x0, 0, w - 1), xb = std::clamp(x0 + 1, 0, w - 1);
    int ya = std::clamp(y0, 0, h - 1), yb = std::clamp(y0 + 1, 0, h - 1);
    Rgba8 top = lerp(img.at(xa, ya), img.at(xb, ya), tx);
    Rgba8 bottom = lerp(img.at(xa, yb), img.at(xb, yb), tx);
    return lerp(top, bottom, ty);
}

}  // namespace

Status rotationTimewarp(const ReferenceView& reference, const Camera& destination,
                        Rgba8 clearColor, Image<Rgba8>* out) {
    const Image<Rgba8>& src = reference.color;
    if (src.empty())
        return errorStatus(ErrorCode::kInvalidArgument, "timewarp: the reference has no colour");
    if (src.width() != reference.camera.width() || src.height() != reference.camera.height())
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("timewarp: reference colour {}x{} does not match its "
                                       "camera's {}x{}",
                                       src.width(), src.height(), reference.camera.width(),
                                       reference.camera.height()));
    // Source pixel from destination pixel: K1 R1^T R2 K2^-1 (R^T = R^-1 for a rotation).
    const DMat3 srcFromDst = pixelFromCamera(reference.camera) *
                             glm::transpose(worldFromCamera(reference.camera)) *
                             worldFromCamera(destination) *
                             glm::inverse(pixelFromCamera(destination));
    const int w = destination.width(), h = destination.height();
    out->resize(w, h);
    for (int y = 0; y < h; ++y) {
        Rgba8* row = out->row(y);
        for (int x = 0; x < w; ++x) {
            DVec3 s = srcFromDst * DVec3(double(x) + 0.5, double(y) + 0.5, 1.0);
            // s.z is the point's depth along the reference's forward axis: <= 0 is behind it.
            bool inside = false;
            double u = 0.0, v = 0.0;
            if (s.z > 0.0) {
                u = s.x / s.z;
                v = s.y / s.z;
                inside = u >= 0.0 && v >= 0.0 && u <= double(src.width()) &&
                         v <= double(src.height());
            }
            row[x] = inside ? sampleBilinear(src, u, v) : clearColor;
        }
    }
    return Status::ok();
}

}  // namespace plx::warp
