// Rotation-only timewarp: the identity reproduces the image, a yaw of one pixel's angle shifts
// the columns by one, and pixels with no source read the clear colour.

#include <cmath>

#include <gtest/gtest.h>

#include <plx/warp/warp.h>

namespace plx::warp {
namespace {

constexpr Rgba8 kClear{40, 44, 52, 255};

Camera cameraLooking(Vec3 forwardDir, int w, int h, float fovDegrees = 40.0f) {
    CameraDesc d;
    d.eyePos = {1.0f, 1.5f, 2.0f};
    d.targetPos = d.eyePos + forwardDir;
    d.fovYDegrees = fovDegrees;
    d.width = w;
    d.height = h;
    return Camera::create(d).value();
}

// Red follows the column, green the row, blue a hash: every pixel distinct enough to notice a
// shift, smooth along rows so that bilinear sampling between columns stays predictable.
ReferenceView gradientView(const Camera& cam) {
    ReferenceView v;
    v.camera = cam;
    v.color.resize(cam.width(), cam.height());
    for (int y = 0; y < cam.height(); ++y)
        for (int x = 0; x < cam.width(); ++x)
            v.color.at(x, y) = {uint8_t(3 * x), uint8_t(2 * y), uint8_t((x * 7 + y * 13) % 251),
                                255};
    return v;
}

TEST(Timewarp, IdentityRotationReproducesTheImage) {
    for (float fov : {30.0f, 60.0f, 100.0f}) {
        Camera cam = cameraLooking({0.3f, -0.2f, -1.0f}, 64, 48, fov);
        ReferenceView ref = gradientView(cam);
        Image<Rgba8> out;
        ASSERT_TRUE(rotationTimewarp(ref, cam, kClear, &out).isOk());
        EXPECT_EQ(out, ref.color) << "fov " << fov;
    }
}

TEST(Timewarp, TranslationAloneIsIgnored) {
    Camera cam = cameraLooking({0.0f, 0.0f, -1.0f}, 40, 30);
    CameraDesc moved = cam.desc();
    moved.eyePos += Vec3(0.5f, 0.2f, -0.3f);
    moved.targetPos += Vec3(0.5f, 0.2f, -0.3f);
    Image<Rgba8> out;
    ReferenceView ref = gradientView(cam);
    ASSERT_TRUE(rotationTimewarp(ref, Camera::create(moved).value(), kClear, &out).isOk());
    EXPECT_EQ(out, ref.color);
}

TEST(Timewarp, YawByOnePixelAngleShiftsColumnsByOne) {
    const int w = 64, h = 48;
    const float fov = 30.0f;
    Camera cam = cameraLooking({0.0f, 0.0f, -1.0f}, w, h, fov);
    // One pixel at the image centre subtends atan(1 / f), f = H / (2 tan(fov / 2)).
    const double f = double(h) / (2.0 * std::tan(double(radians(fov)) * 0.5));
    const double angle = std::atan(1.0 / f);
    // Turning right (clockwise seen from above): the scene moves left in the image, so the
    // destination's pixel x shows the reference's pixel x + 1.
    Vec3 turned{float(std::sin(angle)), 0.0f, float(-std::cos(angle))};
    Camera dst = cameraLooking(turned, w, h, fov);
    ReferenceView ref = gradientView(cam);
    Image<Rgba8> out;
    ASSERT_TRUE(rotationTimewarp(ref, dst, kClear, &out).isOk());
    const int cy = h / 2;
    for (int x = w / 2 - 8; x < w / 2 + 8; ++x) {
        Rgba8 got = out.at(x, cy), want = ref.color.at(x + 1, cy);
        EXPECT_NEAR(got.r, want.r, 1) << "column " << x;
        EXPECT_NEAR(got.g, want.g, 1) << "column " << x;
    }
    // The last column's source lies past the reference's right edge (the shift grows to the
    // edges, never below one pixel).
    for (int y = 0; y < h; ++y) EXPECT_EQ(out.at(w - 1, y), kClear) << "row " << y;
    EXPECT_NE(out.at(0, cy), kClear);
}

TEST(Timewarp, SourceBehindTheReferenceIsClear) {
    Camera cam = cameraLooking({0.0f, 0.0f, -1.0f}, 32, 24, 60.0f);
    Camera back = cameraLooking({0.0f, 0.0f, 1.0f}, 32, 24, 60.0f);
    Image<Rgba8> out;
    ASSERT_TRUE(rotationTimewarp(gradientView(cam), back, kClear, &out).isOk());
    for (int y = 0; y < out.height(); ++y)
        for (int x = 0; x < out.width(); ++x) ASSERT_EQ(out.at(x, y), kClear);
}

TEST(Timewarp, DestinationSizeIsItsCameraAndMismatchIsAnError) {
    Camera cam = cameraLooking({0.0f, 0.0f, -1.0f}, 32, 24);
    Camera big = cameraLooking({0.0f, 0.0f, -1.0f}, 64, 48);
    Image<Rgba8> out;
    ASSERT_TRUE(rotationTimewarp(gradientView(cam), big, kClear, &out).isOk());
    EXPECT_EQ(out.width(), 64);
    EXPECT_EQ(out.height(), 48);
    ReferenceView bad = gradientView(cam);
    bad.color.resize(10, 10);
    EXPECT_FALSE(rotationTimewarp(bad, cam, kClear, &out).isOk());
    bad.color = Image<Rgba8>();
    EXPECT_FALSE(rotationTimewarp(bad, cam, kClear, &out).isOk());
}

}  // namespace
}  // namespace plx::warp
