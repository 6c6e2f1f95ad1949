#include <gtest/gtest.h>

#include <cstdlib>
#include <limits>
#include <map>

#include <plx/gl/gl_renderer.h>

namespace plx::gl {
namespace {

constexpr int kWidth = 64;
constexpr int kHeight = 48;

// Creates the renderer every test uses, or says why the machine cannot run OpenGL 4.5 offscreen.
std::unique_ptr<GlRenderer> makeRenderer(std::string* why) {
    GlConfig config;
    config.threads = 2;
    auto renderer = GlRenderer::create(config);
    if (!renderer) {
        *why = "EGL/OpenGL 4.5 unavailable: " + renderer.status().toString();
        return nullptr;
    }
    return std::move(renderer).value();
}

#define PLX_MAKE_RENDERER_OR_SKIP(name)    \
    std::string skipReason;                \
    auto name = makeRenderer(&skipReason); \
    if (!name) GTEST_SKIP() << skipReason

scene::Mesh quad(const std::string& name, Vec3 lo, Vec3 hi, int material) {
    // Axis-aligned rectangle in the plane z = lo.z, two triangles along the lo-hi diagonal.
    scene::Mesh mesh;
    mesh.name = name;
    mesh.positions = {
        {lo.x, lo.y, lo.z}, {hi.x, lo.y, lo.z}, {hi.x, hi.y, lo.z}, {lo.x, hi.y, lo.z}};
    mesh.indices = {0, 1, 2, 0, 2, 3};
    mesh.materialIndex = material;
    return mesh;
}

// Global triangles: 0-1 far quad (z = -1), 2 a small triangle above it (z = 0); 3-4 near quad
// (z = 1) overlapping the far one; 5 a floor triangle (y = -1.5) that reaches behind the eye and
// so is clipped against the near plane.
scene::Scene testScene() {
    scene::Scene scene;
    scene.materials.push_back({"red", {0.8f, 0.1f, 0.1f, 1.0f}, -1});
    scene.materials.push_back({"blue", {0.1f, 0.2f, 0.9f, 1.0f}, -1});
    scene::Mesh far = quad("far", {-2.0f, -1.2f, -1.0f}, {1.0f, 1.2f, -1.0f}, 0);
    far.positions.push_back({-1.5f, 1.5f, 0.0f});
    far.positions.push_back({-0.5f, 1.5f, 0.0f});
    far.positions.push_back({-1.0f, 2.2f, 0.0f});
    far.indices.insert(far.indices.end(), {4, 5, 6});
    scene.meshes.push_back(far);
    scene.meshes.push_back(quad("near", {-0.5f, -0.8f, 1.0f}, {2.0f, 0.6f, 1.0f}, 1));
    scene::Mesh floor;
    floor.name = "floor";
    floor.positions = {{-2.5f, -1.5f, 0.0f}, {-1.0f, -1.5f, 0.0f}, {-1.8f, -1.5f, 20.0f}};
    floor.indices = {0, 1, 2};
    scene.meshes.push_back(floor);
    EXPECT_TRUE(scene.finalize().isOk());
    return scene;
}

Camera testCamera() {
    CameraDesc desc;
    desc.eyePos = {0.0f, 0.0f, 5.0f};
    desc.targetPos = {0.0f, 0.0f, 0.0f};
    desc.nearPlane = 0.1f;
    desc.farPlane = 100.0f;
    desc.width = kWidth;
    desc.height = kHeight;
    return Camera::create(desc).value();
}

// Ray-cast reference for one pixel centre: the ID of the nearest triangle hit, or 0, and
// whether any triangle's edge passes so close to the ray that rasterisation may round either way.
struct Expected {
    uint32_t id = 0;
    bool ambiguous = false;
    int hits = 0;  // triangles the ray passes through
    float invW = 0.0f;
};

Expected castRay(const scene::Scene& scene, const Camera& camera, int x, int y) {
    Mat4 worldFromClip = glm::inverse(camera.clipFromWorld());
    float ndcX = (float(x) + 0.5f) / float(kWidth) * 2.0f - 1.0f;
    float ndcY = 1.0f - (float(y) + 0.5f) / float(kHeight) * 2.0f;
    Vec4 farPoint = worldFromClip * Vec4(ndcX, ndcY, 1.0f, 1.0f);
    Vec3 origin = camera.eyePos();
    Vec3 dir = glm::normalize(Vec3(farPoint) / farPoint.w - origin);
    constexpr float kEdgeMargin = 0.02f;  // barycentric distance treated as "on the edge"
    Expected expected;
    float nearestT = std::numeric_limits<float>::infinity();
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
        const scene::Mesh& mesh = scene.meshes[m];
        for (size_t t = 0; t < mesh.triangleCount(); ++t) {
            Vec3 a = mesh.positions[mesh.indices[3 * t]];
            Vec3 b = mesh.positions[mesh.indices[3 * t + 1]];
            Vec3 c = mesh.positions[mesh.indices[3 * t + 2]];
            // Moller-Trumbore ray/triangle intersection.
            Vec3 e1 = b - a, e2 = c - a, p = glm::cross(dir, e2);
            float det = glm::dot(e1, p);
            if (std::abs(det) < 1e-9f) continue;
            Vec3 s = origin - a, q = glm::cross(s, e1);
            float u = glm::dot(s, p) / det, v = glm::dot(dir, q) / det;
            float hitT = glm::dot(e2, q) / det;
            float minBary = std::min({u, v, 1.0f - u - v});
            if (hitT <= 0.0f || minBary < -kEdgeMargin) continue;
            if (minBary < kEdgeMargin) {
                expected.ambiguous = true;
                continue;
            }
            ++expected.hits;
            if (hitT < nearestT) {
                nearestT = hitT;
                expected.id = uint32_t(scene.firstTriangle(m) + t + 1);
                expected.invW = 1.0f / glm::dot(dir * hitT, camera.forwardDir());
            }
        }
    }
    return expected;
}

TEST(GlRenderer, CreatesOpenGl45ContextAndSetsThreads) {
    PLX_MAKE_RENDERER_OR_SKIP(renderer);
    EXPECT_FALSE(renderer->rendererName().empty());
    EXPECT_NE(renderer->versionString().find("4."), std::string::npos);
    EXPECT_EQ(renderer->threads(), 2);
    const char* env = std::getenv("LP_NUM_THREADS");
    ASSERT_NE(env, nullptr);
    EXPECT_STREQ(env, "2");
}

TEST(GlRenderer, IdsMatchRayCastReferenceWithGlobalNumbering) {
    PLX_MAKE_RENDERER_OR_SKIP(renderer);
    scene::Scene scene = testScene();
    Camera camera = testCamera();
    ASSERT_TRUE(renderer->upload(scene).isOk());
    Image<uint32_t> ids;
    Image<float> depth;
    auto stats = renderer->render(camera, {nullptr, &ids, &depth});
    ASSERT_TRUE(stats.isOk()) << stats.status().toString();
    EXPECT_EQ(stats->trianglesSubmitted, 6u);
    EXPECT_EQ(stats->drawCalls, 3u);
    ASSERT_EQ(ids.width(), kWidth);
    ASSERT_EQ(ids.height(), kHeight);

    int checked = 0, mismatches = 0, overlapPixels = 0;
    std::map<uint32_t, int> seen;
    for (int y = 0; y < kHeight; ++y) {
        for (int x = 0; x < kWidth; ++x) {
            Expected expected = castRay(scene, camera, x, y);
            if (expected.ambiguous) continue;
            ++checked;
            uint32_t got = ids.at(x, y);
            ++seen[got];
            if (got != expected.id) {
                ++mismatches;
                ADD_FAILURE() << "pixel (" << x << ", " << y << "): ID " << got << ", expected "
                              << expected.id;
                continue;
            }
            if (expected.id == 0) {
                EXPECT_EQ(depth.at(x, y), 0.0f);
            } else {
                EXPECT_NEAR(depth.at(x, y), expected.invW, 1e-4f * expected.invW);
            }
            // Where the near quad covers the far quad, the near quad's IDs must win.
            if (expected.hits >= 2 && (expected.id == 4 || expected.id == 5)) ++overlapPixels;
        }
    }
    EXPECT_EQ(mismatches, 0);
    EXPECT_GT(checked, kWidth * kHeight * 3 / 4);
    EXPECT_GT(overlapPixels, 20);
    for (uint32_t id = 0; id <= 6; ++id) EXPECT_GT(seen[id], 0) << "ID " << id << " never seen";
    EXPECT_EQ(seen.size(), 7u);
}

// A mesh far larger than any internal vertex batch of the driver: every pixel's ID must name a
// triangle whose projected bounding box holds the pixel centre, so primitive IDs stay counted
// from the start of the draw however the driver splits it.
TEST(GlRenderer, IdsStayGlobalAcrossLargeMeshes) {
    PLX_MAKE_RENDERER_OR_SKIP(renderer);
    scene::Scene scene;
    scene.meshes.push_back(quad("lead", {-9.0f, -9.0f, -5.0f}, {-8.0f, -8.0f, -5.0f}, 0));
    constexpr int kCells = 256;
    scene::Mesh grid;
    grid.name = "grid";
    for (int j = 0; j <= kCells; ++j) {
        for (int i = 0; i <= kCells; ++i) {
            grid.positions.push_back(
                {-3.0f + 6.0f * float(i) / kCells, -2.0f + 4.0f * float(j) / kCells, 0.0f});
        }
    }
    for (int j = 0; j < kCells; ++j) {
        for (int i = 0; i < kCells; ++i) {
            uint32_t a = uint32_t(j * (kCells + 1) + i), b = a + 1, c = a + kCells + 2,
                     d = a + kCells + 1;
            grid.indices.insert(grid.indices.end(), {a, b, c, a, c, d});
        }
    }
    scene.meshes.push_back(grid);
    ASSERT_TRUE(scene.finalize().isOk());
    Camera camera = testCamera();
    ASSERT_TRUE(renderer->upload(scene).isOk());
    Image<uint32_t> ids;
    ASSERT_TRUE(renderer->render(camera, {nullptr, &ids, nullptr}).isOk());

    const scene::Mesh& mesh = scene.meshes[1];
    size_t first = scene.firstTriangle(1);
    int covered = 0;
    uint32_t largest = 0;
    for (int y = 0; y < kHeight; ++y) {
        for (int x = 0; x < kWidth; ++x) {
            uint32_t id = ids.at(x, y);
            if (id == 0) continue;
            ++covered;
            largest = std::max(largest, id);
            ASSERT_GE(size_t(id - 1), first) << "pixel " << x << "," << y;
            size_t t = id - 1 - first;
            ASSERT_LT(t, mesh.triangleCount());
            Vec2 lo(std::numeric_limits<float>::infinity()), hi(-lo);
            for (int k = 0; k < 3; ++k) {
                Vec2 p;
                ASSERT_TRUE(camera.projectToPixel(mesh.positions[mesh.indices[3 * t + k]], &p));
                lo = glm::min(lo, p);
                hi = glm::max(hi, p);
            }
            constexpr float kSlack = 0.01f;  // pixels; rasterisation snaps to 1/256 pixel
            Vec2 centre(float(x) + 0.5f, float(y) + 0.5f);
            EXPECT_TRUE(centre.x >= lo.x - kSlack && centre.x <= hi.x + kSlack &&
                        centre.y >= lo.y - kSlack && centre.y <= hi.y + kSlack)
                << "pixel " << x << "," << y << " holds ID " << id;
        }
    }
    EXPECT_GT(covered, kWidth * kHeight / 2);
    EXPECT_GT(largest, first + mesh.triangleCount() * 3 / 4) << "upper rows of the grid drawn";
}

TEST(GlRenderer, ShadesFlatLambertPlusAmbientInSrgb) {
    PLX_MAKE_RENDERER_OR_SKIP(renderer);
    scene::Scene scene = testScene();
    Camera camera = testCamera();
    ASSERT_TRUE(renderer->upload(scene).isOk());
    Image<Rgba8> color;
    Image<uint32_t> ids;
    ASSERT_TRUE(renderer->render(camera, {&color, &ids, nullptr}).isOk());
    Vec3 lightDir = glm::normalize(Vec3(0.35f, 0.85f, 0.4f));
    float facingZ = 0.25f + std::abs(lightDir.z);  // quads face +z
    float facingY = 0.25f + std::abs(lightDir.y);  // the floor faces +y
    int quadPixels = 0;
    for (int y = 0; y < kHeight; ++y) {
        for (int x = 0; x < kWidth; ++x) {
            uint32_t id = ids.at(x, y);
            Rgba8 got = color.at(x, y);
            Rgba8 want = GlConfig{}.clearColor;
            if (id != 0) {
                const scene::Material& mat = scene.materials[size_t(
                    scene.meshes[scene.meshOfTriangle(id - 1)].materialIndex)];
                want = encodeRgb(Vec3(mat.baseColor) * (id == 6 ? facingY : facingZ));
            }
            if (id != 0 && id != 6) ++quadPixels;
            ASSERT_NEAR(got.r, want.r, 1) << "pixel " << x << "," << y << " id " << id;
            ASSERT_NEAR(got.g, want.g, 1) << "pixel " << x << "," << y << " id " << id;
            ASSERT_NEAR(got.b, want.b, 1) << "pixel " << x << "," << y << " id " << id;
            ASSERT_EQ(got.a, 255);
        }
    }
    EXPECT_GT(quadPixels, 100);
}

TEST(GlRenderer, ReportsMisuseAsStatus) {
    PLX_MAKE_RENDERER_OR_SKIP(renderer);
    Camera camera = testCamera();
    auto early = renderer->render(camera);
    ASSERT_FALSE(early.isOk());
    EXPECT_NE(early.status().message().find("before a scene"), std::string::npos);

    scene::Scene stale = testScene();
    stale.meshes[1].indices.insert(stale.meshes[1].indices.end(), {0, 1, 2});
    Status status = renderer->upload(stale);
    EXPECT_FALSE(status.isOk());
    EXPECT_NE(status.message().find("finalize"), std::string::npos);

    scene::Scene badIndex = testScene();
    badIndex.meshes[0].indices[1] = 99;
    EXPECT_NE(renderer->upload(badIndex).message().find("out of range"), std::string::npos);
    EXPECT_FALSE(renderer->render(camera).isOk()) << "a failed upload leaves nothing to draw";

    ASSERT_TRUE(renderer->upload(testScene()).isOk());
    EXPECT_EQ(renderer->timeFrames(camera, 0).status().code(), ErrorCode::kInvalidArgument);
    auto timing = renderer->timeFrames(camera, 2);
    ASSERT_TRUE(timing.isOk());
    EXPECT_EQ(timing->frames, 2);
    EXPECT_EQ(timing->trianglesPerFrame, 6u);

    GlConfig bad;
    bad.threads = -1;
    EXPECT_EQ(GlRenderer::create(bad).status().code(), ErrorCode::kInvalidArgument);
}

TEST(GlRenderer, SharesTheDisplayAndRefusesAThreadCountChange) {
    PLX_MAKE_RENDERER_OR_SKIP(first);
    GlConfig same;
    same.threads = 2;
    auto second = GlRenderer::create(same);
    ASSERT_TRUE(second.isOk()) << second.status().toString();
    GlConfig other;
    other.threads = 3;
    auto third = GlRenderer::create(other);
    ASSERT_FALSE(third.isOk());
    EXPECT_EQ(third.status().code(), ErrorCode::kUnsupported);

    // Both live contexts render independently, switching the current context as needed.
    scene::Scene scene = testScene();
    Camera camera = testCamera();
    ASSERT_TRUE(first->upload(scene).isOk());
    ASSERT_TRUE((*second)->upload(scene).isOk());
    Image<uint32_t> a, b;
    ASSERT_TRUE(first->render(camera, {nullptr, &a, nullptr}).isOk());
    ASSERT_TRUE((*second)->render(camera, {nullptr, &b, nullptr}).isOk());
    EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace plx::gl
