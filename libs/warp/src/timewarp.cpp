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
#include <oneapi/tbb/blocked_range.h>
#include <oneapi/tbb/parallel_for.h>

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

// Bilinear weights in 8.8 fixed point (0..256, so that a sample on a pixel centre, whose
// fraction may come out as 0.9999999, puts all its weight on one pixel and copies it exactly).
uint32_t blend(uint32_t a, uint32_t b, uint32_t c, uint32_t d, uint32_t wx, uint32_t wy) {
    uint32_t top = a * (256 - wx) + b * wx, bottom = c * (256 - wx) + d * wx;
    return (top * (256 - wy) + bottom * wy + 32768) >> 16;
}

// Bilinear sample at continuous pixel coordinates (u, v) (pixel centres at +0.5), inside
// [0, W] x [0, H]; the half pixel at each border clamps to the edge pixels.
Rgba8 sampleBilinear(const Image<Rgba8>& img, float u, float v) {
    const int w = img.width(), h = img.height();
    // u, v >= 0, so fx, fy >= -0.5 and truncating fx + 1 floors it (std::floor is a library
    // call on baseline x86-64, which has no SSE4.1 round instruction).
    float fx = u - 0.5f, fy = v - 0.5f;
    int x0 = int(fx + 1.0f) - 1, y0 = int(fy + 1.0f) - 1;
    uint32_t wx = uint32_t(std::lrint((fx - float(x0)) * 256.0f));
    uint32_t wy = uint32_t(std::lrint((fy - float(y0)) * 256.0f));
    int xa = std::clamp(x0, 0, w - 1), xb = std::clamp(x0 + 1, 0, w - 1);
    const Rgba8* ra = img.row(std::clamp(y0, 0, h - 1));
    const Rgba8* rb = img.row(std::clamp(y0 + 1, 0, h - 1));
    const Rgba8 a = ra[xa], b = ra[xb], c = rb[xa], d = rb[xb];
    return {uint8_t(blend(a.r, b.r, c.r, d.r, wx, wy)), uint8_t(blend(a.g, b.g, c.g, d.g, wx, wy)),
            uint8_t(blend(a.b, b.b, c.b, d.b, wx, wy)), uint8_t(blend(a.a, b.a, c.a, d.a, wx, wy))};
}

// One destination row. Along it the homogeneous source point moves by the matrix's first
// column; it is evaluated from the row start in double (no drift over long rows), divided in
// float.
void timewarpRow(const Image<Rgba8>& src, const DMat3& srcFromDst, int y, Rgba8 clearColor,
                 Rgba8* row, int w) {
    const float srcW = float(src.width()), srcH = float(src.height());
    const DVec3 start = srcFromDst * DVec3(0.5, double(y) + 0.5, 1.0);
    const DVec3 step = srcFromDst[0];
    for (int x = 0; x < w; ++x) {
        const DVec3 s = start + double(x) * step;
        // s.z is the point's depth along the reference's forward axis: <= 0 is behind it.
        Rgba8 c = clearColor;
        if (s.z > 0.0) {
            const float inv = 1.0f / float(s.z);
            const float u = float(s.x) * inv, v = float(s.y) * inv;
            if (u >= 0.0f && v >= 0.0f && u <= srcW && v <= srcH) c = sampleBilinear(src, u, v);
        }
        row[x] = c;
    }
}

// Rows per parallel task: a few thousand pixels, enough to amortise a task's cost.
constexpr int kRowsPerTask = 8;

}  // namespace

Status rotationTimewarp(const ReferenceView& reference, const Camera& destination, Rgba8 clearColor,
                        Image<Rgba8>* out) {
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
    const DMat3 srcFromDst =
        pixelFromCamera(reference.camera) * glm::transpose(worldFromCamera(reference.camera)) *
        worldFromCamera(destination) * glm::inverse(pixelFromCamera(destination));
    const int w = destination.width(), h = destination.height();
    out->resize(w, h);
    // Rows are independent: they run on the caller's TBB arena (all cores unless the caller
    // bounds it, as the Warper's pool does for the warp).
    tbb::parallel_for(tbb::blocked_range<int>(0, h, kRowsPerTask),
                      [&](const tbb::blocked_range<int>& rows) {
                          for (int y = rows.begin(); y < rows.end(); ++y)
                              timewarpRow(src, srcFromDst, y, clearColor, out->row(y), w);
                      });
    return Status::ok();
}

}  // namespace plx::warp
