// Properties of the warp: its own pose reproduces a reference, rotations are homographies, a
// plane lands on its true render, clipping and threads never change the image, splat sizes are
// the warp's derivatives, every ISA path equals the scalar one, the two visibility orders
// agree, and bad input gets one-line errors.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <plx/core/cpu.h>
#include <plx/core/metrics.h>
#include <plx/raster/raster.h>
#include <plx/scene/generators.h>
#include <plx/warp/clip.h>
#include <plx/warp/equation.h>
#include <plx/warp/holes.h>
#include <plx/warp/reference.h>
#include <plx/warp/splat.h>
#include <plx/warp/warp.h>

namespace plx::warp {
namespace {

constexpr Splat kSplats[] = {Splat::kDerivative, Splat::kPoint, Splat::kFixed2x2, Splat::kMesh};

std::unique_ptr<raster::Renderer> makeRenderer() {
    return std::move(raster::Renderer::create({2})).value();
}

Camera cameraFor(const Pose& pose, int w, int h, float fov = 60.0f) {
    CameraDesc d;
    d.eyePos = pose.eye;
    d.targetPos = pose.eye + pose.forward;
    d.upDir = pose.up;
    d.fovYDegrees = fov;
    d.width = w;
    d.height = h;
    return *Camera::create(d);
}

// office:1 (or another scene) from its first viewpoint: the pose and a small cube4 set.
struct Office {
    scene::Scene scene;
    std::unique_ptr<raster::Renderer> renderer = makeRenderer();
    Pose pose;
    ReferenceSet set;
    explicit Office(ReferenceLayout layout = ReferenceLayout::kCube4, int face = 96,
                    scene::Scene s = *scene::generateOffice(1))
        : scene(std::move(s)) {
        pose = poseAt(scene.viewpoints.front());
        ReferenceSetOptions o;
        o.layout = layout;
        o.faceSize = face;
        EXPECT_TRUE(renderReferenceSet(*renderer, scene, pose, o, &set).isOk());
    }
    // A destination a little to the right and forward of the reference pose, turned a bit.
    Camera moved(float dx, float dz, float yawDegrees, int w = 160, int h = 120) const {
        Pose p = pose;
        const Vec3 right = glm::normalize(glm::cross(pose.forward, pose.up));
        p.eye += right * dx + pose.forward * dz;
        const float t = radians(yawDegrees);
        p.forward = glm::normalize(pose.forward * std::cos(t) + right * std::sin(t));
        return cameraFor(p, w, h);
    }
};

WarpFrame warpOnce(const ReferenceSet& set, const Camera& dest, const WarpOptions& options,
                   int threads = 2, WarpStats* stats = nullptr) {
    auto warper = std::move(Warper::create(threads)).value();
    WarpFrame frame;
    EXPECT_TRUE(warper->warp(set, dest, options, &frame, stats).isOk());
    return frame;
}

ReferenceSet firstViewOnly(const ReferenceSet& set) {
    ReferenceSet one;
    one.pose = set.pose;
    one.views.push_back(set.views.front());
    return one;
}

// Each layout's views look along the pose's forward, right, back, left, up and down, as many
// as referenceViewCount says; the wide view alone takes the aspect.
TEST(ReferenceSet, LayoutsLookAlongTheirFaces) {
    Pose pose;
    pose.eye = {1.0f, 2.0f, 3.0f};
    pose.forward = {0.0f, 0.0f, -2.0f};
    pose.up = {0.0f, 3.0f, 0.0f};
    const Vec3 f{0, 0, -1}, r{1, 0, 0}, u{0, 1, 0};
    const std::vector<Vec3> along = {f, r, -f, -r, u, -u};
    for (ReferenceLayout layout :
         {ReferenceLayout::kCube4, ReferenceLayout::kCube6, ReferenceLayout::kWide}) {
        SCOPED_TRACE(referenceLayoutName(layout));
        ReferenceSetOptions o;
        o.layout = layout;
        o.faceSize = 90;
        auto cameras = referenceCameras(pose, o);
        ASSERT_TRUE(cameras.isOk());
        ASSERT_EQ(int(cameras->size()), referenceViewCount(layout));
        for (size_t i = 0; i < cameras->size(); ++i) {
            const Camera& c = (*cameras)[i];
            EXPECT_LT(glm::length(c.forwardDir() - along[i]), 1e-5f) << "view " << i;
            EXPECT_EQ(c.eyePos(), pose.eye);
            EXPECT_EQ(c.height(), 90);
            EXPECT_EQ(c.width(), layout == ReferenceLayout::kWide ? 160 : 90);
        }
    }
}

// A server renders every set into the same buffers: what an earlier set left there must not show.
TEST(ReferenceSet, ReusedBuffersHoldOnlyTheNewSet) {
    Office o;
    Pose turned = o.pose;
    turned.eye += Vec3(0.4f, 0.1f, -0.3f);
    turned.forward = glm::normalize(o.pose.forward + Vec3(0.3f, 0.0f, 0.2f));
    ReferenceSetOptions options;
    options.faceSize = 96;
    ReferenceSet fresh;
    ASSERT_TRUE(renderReferenceSet(*o.renderer, o.scene, turned, options, &fresh).isOk());
    ReferenceSet reused = o.set;  // holds the first pose's pixels
    ASSERT_TRUE(renderReferenceSet(*o.renderer, o.scene, turned, options, &reused).isOk());
    ASSERT_EQ(reused.views.size(), fresh.views.size());
    for (size_t v = 0; v < fresh.views.size(); ++v) {
        EXPECT_EQ(std::memcmp(reused.views[v].color.data(), fresh.views[v].color.data(),
                              fresh.views[v].color.pixelCount() * sizeof(Rgba8)),
                  0);
        EXPECT_EQ(std::memcmp(reused.views[v].disparity.data(), fresh.views[v].disparity.data(),
                              fresh.views[v].disparity.pixelCount() * sizeof(float)),
                  0);
        EXPECT_EQ(reused.views[v].rowMaxDisparity, fresh.views[v].rowMaxDisparity);
    }
}

// The row ranges on every ISA path (row_range.inl) are std::min_element's and
// std::max_element's: rendered views of every layout and rows of negative values, -0, +-inf and
// denormals, widths no multiple of a vector.
TEST(ReferenceSet, RowRangesAreEachRowsMinAndMaxOnEveryIsa) {
    const scene::Scene scene = *scene::generateMuseum(2);
    const Pose pose = poseAt(scene.viewpoints.front());
    auto renderer = makeRenderer();
    std::vector<ReferenceView> views;
    for (ReferenceLayout layout :
         {ReferenceLayout::kCube4, ReferenceLayout::kCube6, ReferenceLayout::kWide}) {
        ReferenceSetOptions o;
        o.layout = layout;
        o.faceSize = 75;
        ReferenceSet set;
        ASSERT_TRUE(renderReferenceSet(*renderer, scene, pose, o, &set).isOk());
        views.insert(views.end(), set.views.begin(), set.views.end());
    }
    const float specials[] = {-0.0f,
                              0.0f,
                              -1.5f,
                              2.5f,
                              1e-42f,
                              -1e-42f,
                              std::numeric_limits<float>::infinity(),
                              -std::numeric_limits<float>::infinity()};
    std::mt19937 rng(3);
    for (int width : {1, 7, 8, 9, 33}) {
        ReferenceView v;
        v.disparity.resize(width, 11);
        for (size_t i = 0; i < v.disparity.pixelCount(); ++i)
            v.disparity.data()[i] = specials[rng() % std::size(specials)];
        views.push_back(std::move(v));
    }
    ActiveIsaGuard restore;
    for (Isa isa : runnableIsas()) {
        ASSERT_TRUE(setActiveIsa(isa).isOk());
        for (ReferenceView v : views) {
            computeRowDisparityRange(&v);
            for (int y = 0; y < v.disparity.height(); ++y) {
                const float* row = v.disparity.row(y);
                const int w = v.disparity.width();
                // (As floats: the keys put -0 below +0, min_element takes the first of the two.)
                EXPECT_EQ(v.rowMinDisparity[size_t(y)], *std::min_element(row, row + w))
                    << isaName(isa) << " row " << y;
                EXPECT_EQ(v.rowMaxDisparity[size_t(y)], *std::max_element(row, row + w))
                    << isaName(isa) << " row " << y;
            }
        }
    }
}

TEST(Warp, OwnPoseReproducesTheReference) {
    Office o;
    const ReferenceSet one = firstViewOnly(o.set);
    const ReferenceView& view = one.views.front();
    for (Splat splat : {Splat::kPoint, Splat::kDerivative}) {
        WarpOptions options;
        options.splat = splat;
        options.fillHoles = false;
        WarpStats stats;
        WarpFrame frame = warpOnce(one, view.camera, options, 2, &stats);
        EXPECT_EQ(stats.holePixels, 0) << splatName(splat);
        EXPECT_TRUE(frame.color == view.color) << splatName(splat);
        EXPECT_TRUE(frame.depth == view.disparity) << splatName(splat);
    }
}

TEST(Warp, PureRotationIsTheHomography) {
    Office o;
    const ReferenceView& view = o.set.views.front();
    const Camera dest = o.moved(0.0f, 0.0f, 20.0f);
    const WarpCoefficients w = warpCoefficients(view.camera, dest);
    EXPECT_EQ(w.c, 0.0f);
    EXPECT_EQ(w.f, 0.0f);
    EXPECT_EQ(w.i, 0.0f);
    // The homography reference: the pixel's world ray projected by the destination camera.
    const glm::dmat3 ray = rayFromPixel(view.camera);
    std::mt19937 rng(7);
    for (int n = 0; n < 200; ++n) {
        const int x = int(rng() % 96), y = int(rng() % 96);
        const float delta = view.disparity.at(x, y);
        if (delta <= 0.0f) continue;
        WarpedPoint p;
        if (!warpPixel(w, x, y, delta, &p)) continue;
        const glm::dvec3 dir = ray * glm::dvec3(x + 0.5, y + 0.5, 1.0);
        const glm::dvec3 world = glm::dvec3(view.camera.eyePos()) + dir / double(delta);
        Vec2 expected;
        ASSERT_TRUE(dest.projectToPixel(Vec3(world), &expected));
        EXPECT_NEAR(p.x, expected.x, 2e-3) << x << "," << y;
        EXPECT_NEAR(p.y, expected.y, 2e-3) << x << "," << y;
        // delta' = 1 / (forward distance in the destination).
        const double w2 =
            glm::dot(world - glm::dvec3(dest.eyePos()), glm::dvec3(dest.forwardDir()));
        EXPECT_NEAR(p.delta * w2, 1.0, 1e-4);
    }
}

// A large textured plane (checkerboard) facing +z at z = 0.
scene::Scene checkerPlane() {
    scene::Scene s;
    scene::Texture tex;
    tex.name = "checker";
    // 512 texels over 8 m: a texel is under a pixel at the test's distances, so the squares'
    // edges are sharp and a pixel's colour is one square's or a blend within that pixel.
    Image<Rgba8> img(512, 512);
    for (int y = 0; y < 512; ++y)
        for (int x = 0; x < 512; ++x)
            img.at(x, y) =
                ((x / 64 + y / 64) % 2) ? Rgba8{230, 60, 40, 255} : Rgba8{30, 90, 220, 255};
    tex.mips.push_back(img);
    scene::buildMipChain(&tex);
    s.textures.push_back(tex);
    scene::Material m;
    m.baseColor = {1, 1, 1, 1};
    m.baseColorTexture = 0;
    s.materials.push_back(m);
    scene::Mesh mesh;
    mesh.positions = {{-4, -4, 0}, {4, -4, 0}, {4, 4, 0}, {-4, 4, 0}};
    mesh.normals.assign(4, Vec3(0, 0, 1));
    mesh.uvs = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
    mesh.indices = {0, 1, 2, 0, 2, 3};
    s.meshes.push_back(mesh);
    EXPECT_TRUE(s.finalize().isOk());
    return s;
}

TEST(Warp, PlaneLandsOnItsTrueRenderWithinAPixel) {
    scene::Scene s = checkerPlane();
    auto renderer = makeRenderer();
    Pose pose;
    pose.eye = {0, 0, 3};
    ReferenceSetOptions ro;
    ro.faceSize = 192;
    ro.render.shading = raster::Shading::kTextured;
    ro.render.lit = false;
    ReferenceSet set;
    ASSERT_TRUE(renderReferenceSet(*renderer, s, pose, ro, &set).isOk());
    Pose moved = pose;
    moved.eye = {0.4f, 0.2f, 2.6f};
    moved.forward = glm::normalize(Vec3(-0.1f, -0.05f, -1.0f));
    const Camera dest = cameraFor(moved, 160, 120);
    raster::FrameBuffers truth;
    truth.resize(160, 120);
    renderer->render(s, dest, ro.render, truth.targets());
    for (Splat splat : kSplats) {
        WarpOptions options;
        options.splat = splat;
        WarpStats stats;
        WarpFrame frame = warpOnce(set, dest, options, 2, &stats);
        // Point splats leave gaps where the plane is magnified (the paper's case for sizing
        // splats); the others cover it. Every covered pixel matches the true render at itself or
        // one of its 8 neighbours.
        int misses = 0, count = 0;
        for (int y = 1; y < 119; ++y)
            for (int x = 1; x < 159; ++x) {
                if (truth.depth.at(x, y) <= 0.0f || frame.holeMask.at(x, y) != 0) continue;
                ++count;
                bool hit = false;
                for (int dy = -1; dy <= 1 && !hit; ++dy)
                    for (int dx = -1; dx <= 1 && !hit; ++dx) {
                        const Rgba8 a = frame.color.at(x, y), b = truth.color.at(x + dx, y + dy);
                        hit = std::abs(a.r - b.r) <= 24 && std::abs(a.g - b.g) <= 24 &&
                              std::abs(a.b - b.b) <= 24;
                    }
                misses += !hit;
            }
        if (splat != Splat::kPoint) {
            EXPECT_EQ(stats.holePixels, 0) << splatName(splat);
        }
        EXPECT_GT(count, 10000);
        EXPECT_LT(misses, count / 200) << splatName(splat);
    }
}

TEST(Warp, ClippingNeverChangesTheImage) {
    Office o;
    for (Splat splat : kSplats) {
        for (auto [dx, dz, yaw] :
             {std::tuple{0.0f, 0.0f, 0.0f}, std::tuple{0.3f, 0.4f, 35.0f},
              std::tuple{-0.5f, -0.3f, -80.0f}, std::tuple{0.1f, 0.8f, 170.0f}}) {
            const Camera dest = o.moved(dx, dz, yaw);
            WarpOptions options;
            options.splat = splat;
            WarpStats clipped, full;
            options.clipRows = true;
            WarpFrame a = warpOnce(o.set, dest, options, 2, &clipped);
            options.clipRows = false;
            WarpFrame b = warpOnce(o.set, dest, options, 2, &full);
            EXPECT_TRUE(a.color == b.color) << splatName(splat) << " yaw " << yaw;
            EXPECT_TRUE(a.depth == b.depth) << splatName(splat) << " yaw " << yaw;
            EXPECT_TRUE(a.holeMask == b.holeMask) << splatName(splat) << " yaw " << yaw;
            EXPECT_GT(clipped.rowsSkipped, 0);
            EXPECT_LT(clipped.sourcePixels, full.sourcePixels);
            EXPECT_EQ(full.rowsSkipped + full.rowsCut, 0);
        }
    }
}

TEST(Warp, ThreadsNeverChangeTheImage) {
    Office o;
    const Camera dest = o.moved(0.3f, 0.2f, 25.0f);
    for (Splat splat : kSplats) {
        WarpOptions options;
        options.splat = splat;
        WarpFrame one = warpOnce(o.set, dest, options, 1);
        WarpFrame two = warpOnce(o.set, dest, options, 2);
        options.atomicWrites = true;
        WarpFrame atomic = warpOnce(o.set, dest, options, 2);
        EXPECT_TRUE(one.color == two.color) << splatName(splat);
        EXPECT_TRUE(one.depth == two.depth) << splatName(splat);
        EXPECT_TRUE(one.color == atomic.color) << splatName(splat);
        EXPECT_TRUE(one.depth == atomic.depth) << splatName(splat);
    }
}

TEST(Warp, SplatSizesAreTheWarpsFiniteDifferences) {
    // A plane's disparity is affine in the pixel position, so the one-sided differences are
    // its exact derivatives, and central differences of the warp approximate |dx'/dx| etc.
    Office o;
    const ReferenceView& view = o.set.views.front();
    const Camera dest = o.moved(0.4f, 0.5f, 15.0f);
    const WarpCoefficients w = warpCoefficients(view.camera, dest);
    const float alpha = 0.0011f, beta = -0.0007f, gamma = 0.35f;
    auto delta = [&](int x, int y) { return alpha * float(x) + beta * float(y) + gamma; };
    for (int y = 10; y < 90; y += 9)
        for (int x = 10; x < 90; x += 7) {
            WarpedPoint p, px0, px1, py0, py1;
            ASSERT_TRUE(warpPixel(w, x, y, delta(x, y), &p));
            ASSERT_TRUE(warpPixel(w, x - 1, y, delta(x - 1, y), &px0));
            ASSERT_TRUE(warpPixel(w, x + 1, y, delta(x + 1, y), &px1));
            ASSERT_TRUE(warpPixel(w, x, y - 1, delta(x, y - 1), &py0));
            ASSERT_TRUE(warpPixel(w, x, y + 1, delta(x, y + 1), &py1));
            const float sx = std::fabs(px1.x - px0.x) / 2 + std::fabs(py1.x - py0.x) / 2;
            const float sy = std::fabs(px1.y - px0.y) / 2 + std::fabs(py1.y - py0.y) / 2;
            const float ddx = neighbourDerivative(delta(x - 1, y), delta(x, y), delta(x + 1, y));
            const float ddy = neighbourDerivative(delta(x, y - 1), delta(x, y), delta(x, y + 1));
            const SplatSize s = derivativeSplatSize(w, p.x, p.y, p.denominator, ddx, ddy);
            EXPECT_NEAR(s.sx, sx, 0.01f * sx) << x << "," << y;
            EXPECT_NEAR(s.sy, sy, 0.01f * sy) << x << "," << y;
        }
}

TEST(Warp, EveryIsaPathEqualsTheScalarPath) {
    Office o;
    // A width that is no multiple of 4 or 8: padded rows and the kernels' scalar tails.
    const Camera dest = o.moved(0.25f, 0.3f, 30.0f, 157, 118);
    ActiveIsaGuard restore;
    for (Splat splat : kSplats) {
        WarpOptions options;
        options.splat = splat;
        options.fillHoles = splat == Splat::kPoint;  // the raw mask too, and once the fill
        ASSERT_TRUE(setActiveIsa(Isa::kScalar).isOk());
        WarpFrame reference = warpOnce(o.set, dest, options);
        for (Isa isa : runnableIsas()) {
            ASSERT_TRUE(setActiveIsa(isa).isOk());
            WarpFrame fast = warpOnce(o.set, dest, options);
            EXPECT_TRUE(fast.color == reference.color) << isaName(isa) << " " << splatName(splat);
            EXPECT_TRUE(fast.depth == reference.depth) << isaName(isa) << " " << splatName(splat);
            EXPECT_TRUE(fast.holeMask == reference.holeMask) << isaName(isa);
        }
    }
}

TEST(Warp, ZBufferAndOcclusionCompatibleOrderAgreeOnOneReference) {
    Office o(ReferenceLayout::kWide, 120);
    for (auto [dx, dz] : {std::pair{0.3f, 0.2f}, std::pair{-0.2f, -0.4f}}) {
        const Camera dest = o.moved(dx, dz, 10.0f);
        WarpOptions options;
        options.splat = Splat::kPoint;
        options.fillHoles = false;
        WarpFrame z = warpOnce(o.set, dest, options);
        options.order = WarpOrder::kOcclusionCompatible;
        WarpFrame oc = warpOnce(o.set, dest, options);
        // Two source pixels can meet in one destination pixel from neighbouring epipolar lines,
        // which the order does not rank; a handful of pixels may differ.
        int64_t differ = 0;
        for (int y = 0; y < 120; ++y)
            for (int x = 0; x < 160; ++x) differ += !(z.color.at(x, y) == oc.color.at(x, y));
        EXPECT_LT(differ, 160 * 120 / 200) << dx << "," << dz;
        EXPECT_TRUE(z.holeMask == oc.holeMask);
    }
}

TEST(Warp, CompositesSetsAndFillsHolesFromTheRearSurface) {
    Office o;
    const Camera dest = o.moved(0.5f, 0.6f, 20.0f);
    WarpOptions options;
    options.fillHoles = false;
    WarpStats open, filled;
    WarpFrame a = warpOnce(o.set, dest, options, 2, &open);
    EXPECT_GT(open.holePixels, 0);
    EXPECT_EQ(open.holePixelsLeft, open.holePixels);
    options.fillHoles = true;
    WarpFrame b = warpOnce(o.set, dest, options, 2, &filled);
    EXPECT_EQ(filled.holePixelsLeft, 0);
    int64_t twos = 0;
    for (int y = 0; y < 120; ++y)
        for (int x = 0; x < 160; ++x) {
            EXPECT_EQ(a.holeMask.at(x, y) == 1, b.holeMask.at(x, y) == 2);
            twos += b.holeMask.at(x, y) == 2;
        }
    EXPECT_EQ(twos, filled.holePixels);
    // A second set rendered at the destination's eye covers what the first leaves open.
    Pose second = o.pose;
    second.eye = dest.eyePos();
    ReferenceSet set2;
    ReferenceSetOptions ro;
    ro.faceSize = 96;
    ASSERT_TRUE(renderReferenceSet(*o.renderer, o.scene, second, ro, &set2).isOk());
    const ReferenceSet* both[] = {&set2, &o.set};
    auto warper = std::move(Warper::create(2)).value();
    WarpFrame c;
    WarpStats two;
    options.fillHoles = false;
    ASSERT_TRUE(warper->warp(both, dest, options, &c, &two).isOk());
    EXPECT_LT(two.holePixels, open.holePixels / 4);
}

// An exact newest set is not made worse by an older one: where both cover a pixel the set
// nearest the destination keeps it unless the other is nearer by more than the tolerance
// (holes.h, compositeDepthScales), whichever order the sets come in. The museum: walls all
// round, so no pixel is empty background, which a z-buffer cannot rank (docs/warp-results.md).
TEST(Warp, AnOlderSetDoesNotDegradeAnExactNewestOne) {
    Office o(ReferenceLayout::kCube4, 160, *scene::generateMuseum(1));
    const Camera dest = o.moved(0.0f, 0.0f, 10.0f, 160, 120);
    raster::FrameBuffers fb;
    fb.resize(dest.width(), dest.height());
    o.renderer->render(o.scene, dest, {}, fb.targets());
    // The older set stands 30 cm behind and 20 cm left of the destination, as on a walk.
    Pose older = o.pose;
    const Vec3 right = glm::normalize(glm::cross(o.pose.forward, o.pose.up));
    older.eye -= o.pose.forward * 0.3f + right * 0.2f;
    ReferenceSet olderSet;
    ReferenceSetOptions ro;
    ro.faceSize = 160;
    ASSERT_TRUE(renderReferenceSet(*o.renderer, o.scene, older, ro, &olderSet).isOk());
    WarpOptions options;
    const double one = psnr(warpOnce(o.set, dest, options).color, fb.color);
    const ReferenceSet* orders[][2] = {{&o.set, &olderSet}, {&olderSet, &o.set}};
    auto warper = std::move(Warper::create(2)).value();
    for (auto& sets : orders) {
        WarpFrame two;
        ASSERT_TRUE(warper->warp(sets, dest, options, &two).isOk());
        EXPECT_GE(psnr(two.color, fb.color), one - 0.1)
            << "exact set first: " << (sets[0] == &o.set);
    }
}

// The set nearest the destination is preferred, the first of equals; one set or no tolerance:
// a plain z-buffer.
TEST(Warp, CompositePrefersTheSetNearestTheDestination) {
    ReferenceSet a, b, c;
    a.pose.eye = Vec3(0.0f, 0.0f, 0.0f);
    b.pose.eye = Vec3(1.0f, 0.0f, 0.0f);
    c.pose.eye = Vec3(-1.0f, 0.0f, 0.0f);
    Pose at = a.pose;
    at.eye = Vec3(0.9f, 0.0f, 0.0f);
    const Camera dest = cameraFor(at, 16, 12);
    const ReferenceSet* sets[] = {&a, &b, &c};
    const float handicap = 1.0f / (1.0f + kCompositeTolerance);
    EXPECT_EQ(compositeDepthScales(sets, dest, kCompositeTolerance),
              (std::vector<float>{handicap, 1.0f, handicap}));
    const ReferenceSet* tied[] = {&b, &b};
    EXPECT_EQ(compositeDepthScales(tied, dest, 0.5f), (std::vector<float>{1.0f, 1.0f / 1.5f}));
    EXPECT_EQ(compositeDepthScales(sets, dest, 0.0f), (std::vector<float>{1.0f, 1.0f, 1.0f}));
    EXPECT_EQ(compositeDepthScales(std::span(sets, 1), dest, 0.5f), (std::vector<float>{1.0f}));
}

TEST(Holes, RunTakesTheFartherNeighbour) {
    Image<Rgba8> color(6, 1);
    Image<float> depth(6, 1);
    Image<uint8_t> mask(6, 1);
    color.at(0, 0) = {1, 0, 0, 255};
    depth.at(0, 0) = 0.5f;  // near
    color.at(4, 0) = {2, 0, 0, 255};
    depth.at(4, 0) = 0.1f;  // far: the rear surface
    for (int x : {1, 2, 3}) mask.at(x, 0) = 1;
    mask.at(5, 0) = 1;
    EXPECT_EQ(fillRearSurface(&color, &depth, &mask, {}), 4);
    for (int x : {1, 2, 3}) EXPECT_EQ(color.at(x, 0).r, 2);
    EXPECT_EQ(color.at(5, 0).r, 2);
    EXPECT_EQ(mask.at(2, 0), 2);
}

TEST(Warp, StereoEyesAreTheShiftedWarps) {
    Office o;
    const Camera center = o.moved(0.1f, 0.1f, 5.0f);
    auto warper = std::move(Warper::create(2)).value();
    const ReferenceSet* sets[] = {&o.set};
    WarpFrame left, right;
    ASSERT_TRUE(warpStereo(*warper, sets, center, 0.064f, {}, &left, &right).isOk());
    CameraDesc d = center.desc();
    d.eyePos += center.rightDir() * 0.032f;
    d.targetPos += center.rightDir() * 0.032f;
    WarpFrame expected = warpOnce(o.set, *Camera::create(d), {});
    EXPECT_TRUE(right.color == expected.color);
    EXPECT_FALSE(left.color == right.color);
    const Status bad = warpStereo(*warper, sets, center, -1.0f, {}, &left, &right);
    EXPECT_FALSE(bad.isOk());
}

void expectOneLineError(const Status& status, const std::string& word) {
    EXPECT_FALSE(status.isOk());
    EXPECT_EQ(status.message().find('\n'), std::string::npos);
    EXPECT_NE(status.message().find(word), std::string::npos) << status.message();
}

TEST(Warp, BadInputGetsOneLineErrors) {
    scene::Scene s = *scene::generateOffice(1);
    auto renderer = makeRenderer();
    ReferenceSet set;
    Pose pose;
    pose.eye.x = std::nanf("");
    expectOneLineError(renderReferenceSet(*renderer, s, pose, {}, &set), "eye");
    pose = {};
    pose.up = pose.forward;
    expectOneLineError(renderReferenceSet(*renderer, s, pose, {}, &set), "parallel");
    pose = {};
    ReferenceSetOptions o;
    o.faceSize = 0;
    expectOneLineError(renderReferenceSet(*renderer, s, pose, o, &set), "face size");
    o = {};
    o.wideFovDegrees = 180.0f;
    expectOneLineError(renderReferenceSet(*renderer, s, pose, o, &set), "field of view");
    // The wide view's aspect bounds its width alone: a cube face above the largest side over
    // that aspect is square, and refused only above the largest side itself.
    o = {};
    o.faceSize = 12000;
    ASSERT_TRUE(referenceCameras(pose, o).isOk());
    o.layout = ReferenceLayout::kWide;
    expectOneLineError(referenceCameras(pose, o).status(),
                       "a wide view of 12000 rows at aspect 1.77778 would be 21333 pixels wide");
    o.wideAspect = std::numeric_limits<float>::quiet_NaN();
    expectOneLineError(referenceCameras(pose, o).status(), "wide aspect nan is not a positive");
    o.wideAspect = 16.0f / 9.0f;
    o.layout = ReferenceLayout::kCube6;
    o.faceSize = Camera::kMaxImageSide + 1;
    expectOneLineError(referenceCameras(pose, o).status(), "face size");
    expectOneLineError(parseSplat("blob").status(), "blob");
    expectOneLineError(parseReferenceLayout("cube5").status(), "cube5");
    EXPECT_EQ(*parseReferenceLayout("wide"), ReferenceLayout::kWide);
    EXPECT_EQ(*parseSplat("fixed"), Splat::kFixed2x2);
    auto warper = std::move(Warper::create(1)).value();
    WarpFrame frame;
    expectOneLineError(warper->warp(ReferenceSet{}, cameraFor({}, 32, 32), {}, &frame),
                       "no reference views");
    ReferenceSet broken;
    broken.views.resize(1);
    expectOneLineError(warper->warp(broken, cameraFor({}, 32, 32), {}, &frame), "size");
    expectOneLineError(Warper::create(-1).status(), "threads");
    // Enums cast from numbers outside their enumerators are refused, not read as a default.
    o = {};
    o.layout = ReferenceLayout(7);
    expectOneLineError(renderReferenceSet(*renderer, s, pose, o, &set), "unknown reference layout");
    o.faceSize = 16;
    o.layout = ReferenceLayout::kCube4;
    ASSERT_TRUE(renderReferenceSet(*renderer, s, pose, o, &set).isOk());
    WarpOptions badSplat, badOrder;
    badSplat.splat = Splat(9);
    badOrder.order = WarpOrder(-1);
    for (const WarpOptions& options : {badSplat, badOrder})
        expectOneLineError(warper->warp(set, cameraFor({}, 32, 32), options, &frame),
                           "unknown splat or order");
}

}  // namespace
}  // namespace plx::warp
