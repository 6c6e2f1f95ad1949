#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <numeric>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include <plx/raster/raster.h>
#include <plx/raster/span_fill.h>

#include "isa_paths.h"

namespace plx::raster {
namespace {

using scene::Mesh;
using scene::Scene;

Camera makeCamera(Vec3 eye, Vec3 target, int w, int h, float fov = 60.0f, float nearPlane = 0.05f,
                  float farPlane = 5000.0f) {
    CameraDesc d;
    d.eyePos = eye;
    d.targetPos = target;
    d.width = w;
    d.height = h;
    d.fovYDegrees = fov;
    d.nearPlane = nearPlane;
    d.farPlane = farPlane;
    auto cam = Camera::create(d);
    PLX_CHECK(cam.isOk());
    return *cam;
}

// A plane of n x n quads spanning [-half, half]^2 in its local xy, interior vertices jittered
// in-plane, placed by `worldFromLocal`.
Scene tessellatedPlane(int n, float half, const Mat4& worldFromLocal, std::mt19937& rng) {
    std::uniform_real_distribution<float> jitter(-0.35f, 0.35f);
    Mesh m;
    float step = 2.0f * half / float(n);
    for (int j = 0; j <= n; ++j) {
        for (int i = 0; i <= n; ++i) {
            float x = -half + step * float(i), y = -half + step * float(j);
            if (i > 0 && i < n) x += jitter(rng) * step;
            if (j > 0 && j < n) y += jitter(rng) * step;
            m.positions.push_back(Vec3(worldFromLocal * Vec4(x, y, 0.0f, 1.0f)));
        }
    }
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            uint32_t a = uint32_t(j * (n + 1) + i), b = a + 1, c = a + uint32_t(n + 1), d = c + 1;
            bool flip = (i + j) % 2;  // alternate diagonals so edges run both ways
            if (flip) {
                m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
            } else {
                m.indices.insert(m.indices.end(), {a, b, c, b, d, c});
            }
        }
    }
    Scene s;
    s.meshes.push_back(std::move(m));
    PLX_CHECK(s.finalize().isOk());
    return s;
}

// Random triangles in a box around the origin, some crossing the near plane or behind the eye.
Scene randomSoup(int count, uint32_t seed, bool withTexture) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(-4.0f, 4.0f), off(-1.5f, 1.5f), uv(-1.0f, 2.0f);
    Scene s;
    for (int meshIndex = 0; meshIndex < 3; ++meshIndex) {
        Mesh m;
        m.materialIndex = meshIndex % 2;
        for (int t = 0; t < count; ++t) {
            Vec3 c(pos(rng), pos(rng), pos(rng) * 1.5f);
            for (int k = 0; k < 3; ++k) {
                m.positions.push_back(c + Vec3(off(rng), off(rng), off(rng)));
                m.uvs.push_back(Vec2(uv(rng), uv(rng)));
                m.indices.push_back(uint32_t(m.positions.size() - 1));
            }
        }
        s.meshes.push_back(std::move(m));
    }
    s.materials.push_back({"red", {0.9f, 0.2f, 0.1f, 1.0f}, -1});
    s.materials.push_back({"tex", {1.0f, 1.0f, 1.0f, 1.0f}, withTexture ? 0 : -1});
    if (withTexture) {
        scene::Texture tex;
        tex.name = "checker";
        Image<Rgba8> img(16, 8);
        for (int y = 0; y < 8; ++y)
            for (int x = 0; x < 16; ++x)
                img.at(x, y) = ((x / 2 + y / 2) % 2) ? Rgba8{250, 240, 30, 255}
                                                     : Rgba8{20, 60, 200, 255};
        tex.mips.push_back(img);
        scene::buildMipChain(&tex);
        s.textures.push_back(std::move(tex));
    }
    PLX_CHECK(s.finalize().isOk());
    return s;
}

// A UV sphere with smooth normals and UVs, appended to the scene as its own mesh.
void addSphere(Scene* s, Vec3 center, float radius, int rings, int segments, int material) {
    Mesh m;
    m.materialIndex = material;
    for (int r = 0; r <= rings; ++r) {
        float phi = kPi * float(r) / float(rings);
        for (int g = 0; g <= segments; ++g) {
            float theta = 2.0f * kPi * float(g) / float(segments);
            Vec3 n(std::sin(phi) * std::cos(theta), std::cos(phi), -std::sin(phi) * std::sin(theta));
            m.positions.push_back(center + radius * n);
            m.normals.push_back(n);
            m.uvs.push_back(Vec2(2.0f * float(g) / float(segments), float(r) / float(rings)));
        }
    }
    for (int r = 0; r < rings; ++r) {
        for (int g = 0; g < segments; ++g) {
            uint32_t a = uint32_t(r * (segments + 1) + g), b = a + 1, c = a + uint32_t(segments + 1),
                     d = c + 1;
            m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
        }
    }
    s->meshes.push_back(std::move(m));
}

std::unique_ptr<Renderer> makeRenderer(int threads, int tileSize = 64) {
    auto r = Renderer::create({threads, tileSize});
    PLX_CHECK(r.isOk());
    return std::move(r).value();
}

void expectSameTargets(FrameBuffers& a, FrameBuffers& b, const std::string& what) {
    EXPECT_TRUE(a.id == b.id) << what << ": ID targets differ";
    EXPECT_TRUE(a.depth == b.depth) << what << ": depth targets differ";
    EXPECT_TRUE(a.color == b.color) << what << ": colour targets differ";
}

// Counts how many triangles cover each pixel by drawing them one at a time.
Image<int> coverageCounts(const Scene& s, const Camera& cam, Renderer& r) {
    Image<int> counts(cam.width(), cam.height(), 0);
    FrameBuffers fb;
    fb.resize(cam.width(), cam.height());
    for (uint32_t t = 0; t < s.triangleCount(); ++t) {
        std::span<const uint32_t> one(&t, 1);
        r.renderSubset(s, cam, one, {}, fb.targets());
        for (size_t i = 0; i < fb.id.pixelCount(); ++i) counts.data()[i] += fb.id.data()[i] != 0;
    }
    return counts;
}

// Every TEST_P of this suite runs once per ISA path this process can run (runnableIsas: the
// build's and the CPU's), so each path's kernels meet the scalar reference renderer and the
// golden images; the renderer takes the active path at the start of each frame.
class RasterPath : public test::IsaPathTest {};
PLX_INSTANTIATE_ISA_PATHS(RasterPath);

TEST_P(RasterPath, TessellatedPlaneCoversEveryPixelExactlyOnce) {
    std::mt19937 rng(1234);
    std::uniform_real_distribution<float> angle(-1.0f, 1.0f), dist(0.5f, 4.0f);
    auto r = makeRenderer(2, 16);
    for (int pose = 0; pose < 12; ++pose) {
        // A large plane through the origin with a random orientation; the camera looks at it
        // from the front at up to ~55 degrees off its normal, so the plane fills the image and
        // crosses the guard band (clipped triangles take part too).
        Mat4 worldFromLocal = glm::rotate(Mat4(1.0f), angle(rng) * kPi, Vec3(0, 0, 1));
        worldFromLocal = glm::rotate(Mat4(1.0f), angle(rng) * 0.9f, Vec3(1, 0, 0)) * worldFromLocal;
        Scene s = tessellatedPlane(8, 2000.0f, worldFromLocal, rng);
        Vec3 normal = glm::normalize(Vec3(worldFromLocal * Vec4(0, 0, 1, 0)));
        Vec3 eye = normal * dist(rng);
        Vec3 target = Vec3(angle(rng), angle(rng), 0.0f) * 0.5f;
        target -= normal * glm::dot(target, normal);
        Camera cam = makeCamera(eye, target, 61, 47, 70.0f);
        Image<int> counts = coverageCounts(s, cam, *r);
        for (int y = 0; y < cam.height(); ++y)
            for (int x = 0; x < cam.width(); ++x)
                ASSERT_EQ(counts.at(x, y), 1) << "pose " << pose << " pixel " << x << "," << y;
    }
}

TEST_P(RasterPath, FillRuleIncludesTopLeftEdgesOnly) {
    // fov 90, 8x8: world x at z=-1 maps to pixel 4x+4, so these vertices sit on pixel centres
    // 2.5 and 5.5: a square of 3x3 pixel centres split along its diagonal.
    Camera cam = makeCamera({0, 0, 0}, {0, 0, -1}, 8, 8, 90.0f);
    auto px = [](float p) { return (p - 4.0f) / 4.0f; };
    for (bool otherDiagonal : {false, true}) {
        Scene s;
        Mesh m;
        m.positions = {{px(2.5f), -px(2.5f), -1}, {px(5.5f), -px(2.5f), -1},
                       {px(2.5f), -px(5.5f), -1}, {px(5.5f), -px(5.5f), -1}};
        m.indices = otherDiagonal ? std::vector<uint32_t>{0, 1, 3, 0, 3, 2}
                                  : std::vector<uint32_t>{0, 1, 2, 1, 3, 2};
        s.meshes.push_back(m);
        ASSERT_TRUE(s.finalize().isOk());
        auto r = makeRenderer(1, 8);
        Image<int> counts = coverageCounts(s, cam, *r);
        for (int y = 0; y < 8; ++y) {
            for (int x = 0; x < 8; ++x) {
                bool inside = x >= 2 && x <= 4 && y >= 2 && y <= 4;  // top and left edges in
                EXPECT_EQ(counts.at(x, y), inside ? 1 : 0) << x << "," << y;
            }
        }
    }
}

TEST_P(RasterPath, IdAtEachPixelIsTheDepthWinner) {
    Scene s = randomSoup(40, 77, false);
    Camera cam = makeCamera({0.3f, 0.5f, 9.0f}, {0, 0, 0}, 80, 60);
    auto r = makeRenderer(2, 16);
    FrameBuffers full;
    full.resize(80, 60);
    r->render(s, cam, {}, full.targets());
    // Expected winner per pixel from single-triangle renders: the largest 1/w, the first drawn on
    // exact ties.
    Image<float> bestDepth(80, 60, 0.0f);
    Image<uint32_t> bestId(80, 60, 0u);
    FrameBuffers one;
    one.resize(80, 60);
    for (uint32_t t = 0; t < s.triangleCount(); ++t) {
        std::span<const uint32_t> single(&t, 1);
        r->renderSubset(s, cam, single, {}, one.targets());
        for (size_t i = 0; i < one.id.pixelCount(); ++i) {
            if (one.id.data()[i] && one.depth.data()[i] > bestDepth.data()[i]) {
                bestDepth.data()[i] = one.depth.data()[i];
                bestId.data()[i] = one.id.data()[i];
            }
        }
    }
    EXPECT_TRUE(full.id == bestId);
    EXPECT_TRUE(full.depth == bestDepth);
    EXPECT_GT(countDistinctIds(full.id), 20u);

    // The optional second layer holds the nearest surface behind the winner.
    Image<float> depth2(80, 60, 0.0f), secondDepth(80, 60, 0.0f);
    Image<uint32_t> id2(80, 60, 0u), secondId(80, 60, 0u);
    RenderTargets layered = full.targets();
    layered.visibility.depth2 = depth2.view();
    layered.visibility.id2 = id2.view();
    r->render(s, cam, {}, layered);
    for (uint32_t t = 0; t < s.triangleCount(); ++t) {
        std::span<const uint32_t> single(&t, 1);
        r->renderSubset(s, cam, single, {}, one.targets());
        for (size_t i = 0; i < one.id.pixelCount(); ++i) {
            float d = one.depth.data()[i];
            if (one.id.data()[i] && one.id.data()[i] != bestId.data()[i] &&
                d > secondDepth.data()[i]) {
                secondDepth.data()[i] = d;
                secondId.data()[i] = one.id.data()[i];
            }
        }
    }
    EXPECT_TRUE(id2 == secondId);
    EXPECT_TRUE(depth2 == secondDepth);
    EXPECT_GT(countDistinctIds(id2), 10u);
    FrameBuffers ref;
    ref.resize(80, 60);
    Image<float> refDepth2(80, 60);
    Image<uint32_t> refId2(80, 60);
    RenderTargets refTargets = ref.targets();
    refTargets.visibility.depth2 = refDepth2.view();
    refTargets.visibility.id2 = refId2.view();
    renderReference(s, cam, {}, refTargets);
    EXPECT_TRUE(refId2 == id2);
    EXPECT_TRUE(refDepth2 == depth2);
}

TEST_P(RasterPath, FastPathEqualsScalarReference) {
    for (bool textured : {false, true}) {
        Scene s = randomSoup(300, textured ? 5 : 6, textured);
        for (Shading shading : {Shading::kFlat, Shading::kGouraud, Shading::kTextured}) {
            for (bool cull : {false, true}) {
                RenderOptions opt;
                opt.shading = shading;
                opt.cullBackFaces = cull;
                // The eye sits inside the soup: many triangles cross the near plane.
                Camera cam = makeCamera({0.5f, 0.2f, 2.0f}, {0, 0, -3}, 123, 77, 75.0f, 0.1f, 30.0f);
                FrameBuffers ref, fast;
                ref.resize(123, 77);
                fast.resize(123, 77);
                renderReference(s, cam, opt, ref.targets());
                for (int threads : {1, 2}) {
                    // Tiles of 8 and 64 are drawn in tile memory and streamed to the targets
                    // (rows of 123 pixels: unaligned row starts); 256 draws in the targets.
                    for (int tile : {8, 64, 256}) {
                        auto r = makeRenderer(threads, tile);
                        RenderStats st = r->render(s, cam, opt, fast.targets());
                        EXPECT_GT(st.trianglesClipped, 0u);
                        expectSameTargets(fast, ref,
                                          std::string(shadingName(shading)) + " threads " +
                                              std::to_string(threads) + " tile " +
                                              std::to_string(tile) + (cull ? " cull" : ""));
                    }
                }
            }
        }
    }
}

// Dense meshes, whose triangles cover a few pixels each (most of them take the narrow flat path,
// which skips the general setup): flat shading, with and without a colour target, against the
// scalar reference, to the bit. Spheres at several distances give triangles from under a pixel
// to about 20 pixels across, both windings and every edge slope; tiles of 8 cut many of them.
TEST_P(RasterPath, DenseMeshFastPathEqualsScalarReference) {
    Scene s;
    addSphere(&s, {0.0f, 0.0f, -3.0f}, 1.2f, 40, 80, 0);
    addSphere(&s, {-1.0f, 0.4f, -6.0f}, 1.5f, 90, 180, 1);
    addSphere(&s, {1.3f, -0.5f, -2.0f}, 0.5f, 12, 24, 0);
    s.materials.push_back({"warm", {0.9f, 0.6f, 0.3f, 1.0f}, -1});
    s.materials.push_back({"cool", {0.2f, 0.5f, 0.9f, 1.0f}, -1});
    PLX_CHECK(s.finalize().isOk());
    Camera cam = makeCamera({0.3f, 0.2f, 1.0f}, {0.0f, 0.0f, -4.0f}, 211, 133, 60.0f);
    for (bool withColor : {true, false}) {
        for (bool cull : {false, true}) {
            RenderOptions opt;
            opt.cullBackFaces = cull;
            FrameBuffers ref, fast;
            ref.resize(211, 133);
            fast.resize(211, 133);
            RenderTargets refTargets = ref.targets(), fastTargets = fast.targets();
            if (!withColor) refTargets.color = fastTargets.color = {};
            renderReference(s, cam, opt, refTargets);
            for (int tile : {8, 64}) {
                auto r = makeRenderer(2, tile);
                r->render(s, cam, opt, fastTargets);
                expectSameTargets(fast, ref,
                                  std::string(withColor ? "colour" : "no colour") + " tile " +
                                      std::to_string(tile) + (cull ? " cull" : ""));
            }
        }
    }
}

// Textured shading on the fast path (eight samples at a time) against the scalar reference, to
// the bit: a receding plane whose UVs run past [0, 1] (wrapped texels, and several mip levels
// across it), a sphere, noise textures (every texel differs, so a wrong texel index shows) with
// and without a mip chain, lit and unlit, with a non-white base colour.
TEST_P(RasterPath, TexturedFastPathEqualsScalarReference) {
    std::mt19937 rng(31);
    Mat4 tilt = glm::rotate(Mat4(1.0f), -1.2f, Vec3(1.0f, 0.0f, 0.0f));
    Scene base = tessellatedPlane(14, 6.0f, tilt, rng);
    for (const Vec3& p : base.meshes[0].positions)
        base.meshes[0].uvs.push_back(Vec2(0.3f * p.x + 0.4f, 0.25f * p.z - 0.6f));
    addSphere(&base, {1.5f, 1.0f, -1.0f}, 1.4f, 10, 20, 0);
    base.materials = {{"tex", {0.9f, 0.7f, 1.0f, 1.0f}, 0}};
    std::uniform_int_distribution<int> byte(0, 255);
    Image<Rgba8> noise(97, 61);
    for (size_t i = 0; i < noise.pixelCount(); ++i)
        noise.data()[i] = Rgba8{uint8_t(byte(rng)), uint8_t(byte(rng)), uint8_t(byte(rng)), 255};
    Camera cam = makeCamera({0.3f, 1.5f, 5.0f}, {0.0f, -0.5f, -2.0f}, 181, 117, 70.0f);
    for (bool mipmapped : {false, true}) {
        Scene s = base;
        scene::Texture tex;
        tex.mips.push_back(noise);
        if (mipmapped) scene::buildMipChain(&tex);
        s.textures.push_back(std::move(tex));
        ASSERT_TRUE(s.finalize().isOk());
        for (bool lit : {false, true}) {
            RenderOptions opt;
            opt.shading = Shading::kTextured;
            opt.lit = lit;
            FrameBuffers ref, fast;
            ref.resize(181, 117);
            fast.resize(181, 117);
            renderReference(s, cam, opt, ref.targets());
            std::set<uint32_t> colours;
            for (size_t i = 0; i < ref.color.pixelCount(); ++i) {
                Rgba8 c = ref.color.data()[i];
                colours.insert(uint32_t(c.r) | uint32_t(c.g) << 8 | uint32_t(c.b) << 16);
            }
            EXPECT_GT(colours.size(), 5000u);  // the texture shows, not a flat colour
            for (int tile : {8, 64}) {
                auto r = makeRenderer(2, tile);
                r->render(s, cam, opt, fast.targets());
                expectSameTargets(fast, ref, std::string(mipmapped ? "mipmapped" : "base level") +
                                                 (lit ? " lit" : " unlit") + " tile " +
                                                 std::to_string(tile));
            }
        }
    }
}

// A wall in front of a soup of triangles: behind it (many), level with it (equal depth fails the
// strict test), in front of it and thin slivers behind it. The tiles skip most of the soup as
// hidden by the wall's depth, and the targets stay exactly the reference's; the same holds when
// the wall was drawn by an earlier call and the targets are not cleared.
TEST_P(RasterPath, OcclusionCullingChangesNothing) {
    Scene wall;
    Mesh quad;
    quad.positions = {{-9, -9, -2}, {9, -9, -2}, {9, 9, -2}, {-9, 9, -2}};
    quad.indices = {0, 1, 2, 0, 2, 3};
    wall.meshes.push_back(quad);
    wall.materials.push_back({"grey", {0.5f, 0.5f, 0.5f, 1.0f}, -1});
    PLX_CHECK(wall.finalize().isOk());
    Scene both = wall;
    std::mt19937 rng(99);
    std::uniform_real_distribution<float> xy(-3.0f, 3.0f), off(-0.6f, 0.6f);
    Mesh soup;
    for (int t = 0; t < 600; ++t) {
        float z = t % 10 == 0 ? -2.0f : (t % 10 == 1 ? -1.5f : -2.5f - float(t % 7));
        Vec3 c(xy(rng), xy(rng), z);
        bool sliver = t % 5 == 0;
        for (int k = 0; k < 3; ++k) {
            Vec3 d(off(rng), sliver ? 0.002f * float(k) : off(rng), z == -2.0f ? 0.0f : off(rng) * 0.2f);
            soup.positions.push_back(c + d);
            soup.indices.push_back(uint32_t(soup.positions.size() - 1));
        }
    }
    both.meshes.push_back(soup);
    both.meshes[1].materialIndex = 0;
    PLX_CHECK(both.finalize().isOk());
    Scene onlySoup = both;
    onlySoup.meshes.erase(onlySoup.meshes.begin());
    PLX_CHECK(onlySoup.finalize().isOk());

    Camera cam = makeCamera({0.2f, 0.1f, 3.0f}, {0, 0, -2}, 150, 100, 70.0f);
    FrameBuffers ref, fast;
    ref.resize(150, 100);
    fast.resize(150, 100);
    renderReference(both, cam, {}, ref.targets());
    for (int tile : {8, 64}) {
        auto r = makeRenderer(2, tile);
        RenderStats st = r->render(both, cam, {}, fast.targets());
        EXPECT_GT(st.tilePairsOccluded, 300u) << "tile " << tile;
        expectSameTargets(fast, ref, "one call, tile " + std::to_string(tile));
        // The wall first, then the soup over the kept targets: the blocks start unknown.
        RenderOptions keep;
        keep.clearTargets = false;
        r->render(wall, cam, {}, fast.targets());
        st = r->render(onlySoup, cam, keep, fast.targets());
        EXPECT_GT(st.tilePairsOccluded, 300u) << "tile " << tile;
        FrameBuffers ref2;
        ref2.resize(150, 100);
        renderReference(wall, cam, {}, ref2.targets());
        renderReference(onlySoup, cam, keep, ref2.targets());
        expectSameTargets(fast, ref2, "two calls, tile " + std::to_string(tile));
    }
}

TEST_P(RasterPath, SubsetOfAllTrianglesReproducesFullRender) {
    Scene s = randomSoup(200, 9, true);
    Camera cam = makeCamera({1, 2, 9}, {0, 0, 0}, 96, 64);
    auto r = makeRenderer(2, 32);
    RenderOptions opt;
    opt.shading = Shading::kTextured;
    FrameBuffers full, subset, ref;
    full.resize(96, 64);
    subset.resize(96, 64);
    ref.resize(96, 64);
    r->render(s, cam, opt, full.targets());
    std::vector<uint32_t> all(s.triangleCount());
    for (uint32_t i = 0; i < all.size(); ++i) all[i] = i;
    r->renderSubset(s, cam, all, opt, subset.targets());
    expectSameTargets(subset, full, "subset of all");
    // A partial subset matches the reference drawing the same list.
    std::vector<uint32_t> some;
    for (uint32_t i = 0; i < all.size(); i += 3) some.push_back(i);
    std::span<const uint32_t> someSpan(some);
    r->renderSubset(s, cam, some, opt, subset.targets());
    renderReference(s, cam, opt, ref.targets(), &someSpan);
    expectSameTargets(subset, ref, "partial subset");
    std::set<uint32_t> ids(subset.id.data(), subset.id.data() + subset.id.pixelCount());
    for (uint32_t id : ids) EXPECT_TRUE(id == 0 || (id - 1) % 3 == 0) << id;
}

// Fu's span-restricted scan conversion: clearing random spans of a full render and drawing every
// triangle into just those spans gives back the full render there, to the bit, and leaves every
// other pixel alone; triangles straddling the near plane and the image border included.
TEST_P(RasterPath, SpanFillEqualsTheFullRenderAtSpanPixels) {
    Scene s = randomSoup(200, 9, true);
    std::mt19937 rng(17);
    for (Shading shading : {Shading::kFlat, Shading::kGouraud, Shading::kTextured}) {
        for (Vec3 eye : {Vec3(1, 2, 9), Vec3(0.5f, 0.3f, 2.0f)}) {
            Camera cam = makeCamera(eye, {0, 0, 0}, 96, 64, 60.0f, 0.5f);
            RenderOptions opt;
            opt.shading = shading;
            FrameBuffers full, spans;
            full.resize(96, 64);
            makeRenderer(2, 32)->render(s, cam, opt, full.targets());
            spans = full;
            std::uniform_int_distribution<int> row(0, 63), col(-4, 99), len(0, 30);
            std::vector<PixelSpan> list;
            Image<uint8_t> inSpan(96, 64, 0);
            for (int i = 0; i < 60; ++i) {
                PixelSpan p{row(rng), col(rng), 0};
                p.x1 = p.x0 + len(rng);
                // Spans are disjoint: a pixel listed twice would be drawn twice.
                bool overlaps = false;
                for (int x = std::max(p.x0, 0); x <= std::min(p.x1, 95); ++x)
                    overlaps |= inSpan.at(x, p.y) != 0;
                if (overlaps) continue;
                for (int x = std::max(p.x0, 0); x <= std::min(p.x1, 95); ++x) {
                    inSpan.at(x, p.y) = 1;
                    spans.color.at(x, p.y) = opt.clearColor;
                    spans.depth.at(x, p.y) = 0.0f;
                    spans.id.at(x, p.y) = 0;
                }
                list.push_back(p);
            }
            std::sort(list.begin(), list.end(),
                      [](const PixelSpan& a, const PixelSpan& b) { return a.y < b.y; });
            // Odd triangles through the overload that takes their corners, which says whether
            // the triangle was set up: always when it wrote, and not for all of them.
            int64_t written = 0;
            uint32_t setUpCount = 0;
            for (uint32_t t = 0; t < s.triangleCount(); ++t) {
                if (t % 2 == 0) {
                    written += drawTriangleInSpans(s, t, cam, opt, spans.targets(), list);
                    continue;
                }
                bool setUp = false;
                const int64_t w = drawTriangleInSpans(s, t, s.triangleCorners(t), cam, opt,
                                                      spans.targets(), list, &setUp);
                EXPECT_TRUE(setUp || w == 0) << "triangle " << t;
                setUpCount += setUp;
                written += w;
            }
            EXPECT_GT(written, 0);
            EXPECT_GT(setUpCount, 0u);
            EXPECT_LT(setUpCount, s.triangleCount() / 2);
            expectSameTargets(spans, full, std::string("span fill ") + shadingName(shading));
        }
    }
}

// Every pixel in short spans, so that every span test of a triangle's rows runs, four spans at a
// time where the build has vectors: the span fill of all triangles gives back the full render.
TEST_P(RasterPath, SpanFillOverEveryPixelEqualsTheFullRender) {
    Scene s = randomSoup(300, 23, false);
    std::mt19937 rng(29);
    std::uniform_int_distribution<int> len(0, 6);
    for (Vec3 eye : {Vec3(1, 2, 9), Vec3(0.5f, 0.3f, 2.0f), Vec3(-0.2f, 0.1f, 0.8f)}) {
        Camera cam = makeCamera(eye, {0, 0, 0}, 96, 64, 60.0f, 0.5f);
        RenderOptions opt;
        FrameBuffers full, spans;
        full.resize(96, 64);
        makeRenderer(2, 32)->render(s, cam, opt, full.targets());
        spans.resize(96, 64);
        spans.color.view().fill(opt.clearColor);
        std::vector<PixelSpan> list;
        for (int y = 0; y < 64; ++y)
            for (int x = 0; x < 96;) {
                const int x1 = std::min(95, x + len(rng));
                list.push_back({y, x, x1});
                x = x1 + 1;
            }
        int64_t written = 0;
        for (uint32_t t = 0; t < s.triangleCount(); ++t)
            written += drawTriangleInSpans(s, t, cam, opt, spans.targets(), list);
        EXPECT_GT(written, 96 * 64 / 2);
        expectSameTargets(spans, full, "span fill over every pixel");
    }
}

// Subsets are binned in equal chunks, a whole number per thread: sizes around the chunk
// boundaries, for thread counts that do and do not divide them, all match the reference.
TEST_P(RasterPath, SubsetsOfEverySizeMatchTheReference) {
    Scene s = randomSoup(1100, 4, false);  // 3,300 triangles in three meshes
    Camera cam = makeCamera({0.5f, 1, 9}, {0, 0, 0}, 80, 56);
    FrameBuffers subset, ref;
    subset.resize(80, 56);
    ref.resize(80, 56);
    std::vector<uint32_t> order(s.triangleCount());
    std::iota(order.begin(), order.end(), 0u);
    std::shuffle(order.begin(), order.end(), std::mt19937(7));
    for (int threads : {1, 2, 3}) {
        auto r = makeRenderer(threads, 16);
        for (size_t n : {size_t(1), size_t(2), size_t(3), size_t(1023), size_t(1024), size_t(1025),
                         size_t(1537), size_t(3300)}) {
            std::vector<uint32_t> list(order.begin(), order.begin() + ptrdiff_t(n));
            std::sort(list.begin(), list.end());
            std::span<const uint32_t> listSpan(list);
            RenderStats st = r->renderSubset(s, cam, list, {}, subset.targets());
            EXPECT_EQ(st.trianglesSubmitted, n);
            renderReference(s, cam, {}, ref.targets(), &listSpan);
            expectSameTargets(subset, ref,
                              std::to_string(n) + " triangles, threads " + std::to_string(threads));
        }
    }
}

// Tiles are drawn in per-thread tile memory that each tile leaves cleared for the next: every
// frame must still start from its own clear colour, after frames with other colours, without a
// colour target, and with partial tiles at the image's edges (90x70 is not a multiple of 16).
TEST_P(RasterPath, TileMemoryStartsEveryFrameFromItsClearColour) {
    Scene s = randomSoup(300, 2, false);
    Camera cam = makeCamera({0.5f, 1, 9}, {0, 0, 0}, 90, 70);
    FrameBuffers fast, ref;
    fast.resize(90, 70);
    ref.resize(90, 70);
    for (int threads : {1, 2}) {
        auto r = makeRenderer(threads, 16);
        for (int frame = 0; frame < 5; ++frame) {
            RenderOptions opt;
            opt.clearColor = {uint8_t(10 * frame), 200, uint8_t(255 - frame), 255};
            if (frame == 2) {  // depth and IDs only: the colour planes are left as they are
                RenderTargets noColour = fast.targets();
                noColour.color = {};
                r->render(s, cam, opt, noColour);
            }
            r->render(s, cam, opt, fast.targets());
            renderReference(s, cam, opt, ref.targets());
            expectSameTargets(
                fast, ref,
                "frame " + std::to_string(frame) + ", threads " + std::to_string(threads));
        }
    }
}

TEST_P(RasterPath, NearPlaneClippingKeepsOnlyGeometryBeyondNear) {
    // A floor that runs under and behind the eye: it must cover the lower half of the image up
    // to the bottom row, and nothing may be nearer than the near plane.
    Scene s;
    Mesh m;
    m.positions = {{-50, 0, 50}, {50, 0, 50}, {50, 0, -50}, {-50, 0, -50}};
    m.indices = {0, 1, 2, 0, 2, 3};
    s.meshes.push_back(m);
    ASSERT_TRUE(s.finalize().isOk());
    const float nearPlane = 0.5f;
    Camera cam = makeCamera({0, 1, 0}, {0, 0.2f, -5}, 64, 48, 90.0f, nearPlane, 200.0f);
    auto r = makeRenderer(2, 16);
    FrameBuffers fb;
    fb.resize(64, 48);
    RenderStats st = r->render(s, cam, {}, fb.targets());
    EXPECT_GT(st.trianglesClipped, 0u);
    for (int x = 0; x < 64; ++x) EXPECT_NE(fb.id.at(x, 47), 0u) << x;
    for (int x = 0; x < 64; ++x) EXPECT_EQ(fb.id.at(x, 0), 0u) << x;  // sky
    for (size_t i = 0; i < fb.depth.pixelCount(); ++i)
        EXPECT_LE(fb.depth.data()[i], 1.0f / nearPlane * 1.0001f);
    // Triangles entirely behind the eye draw nothing.
    Camera away = makeCamera({0, 1, 0}, {0, 1, 5}, 64, 48, 60.0f, nearPlane, 20.0f);
    Scene behind;
    Mesh b;
    b.positions = {{-1, 0, -3}, {1, 0, -3}, {0, 2, -3}};
    b.indices = {0, 1, 2};
    behind.meshes.push_back(b);
    ASSERT_TRUE(behind.finalize().isOk());
    r->render(behind, away, {}, fb.targets());
    EXPECT_EQ(countDistinctIds(fb.id), 0u);
}

TEST_P(RasterPath, BackFaceCullingUsesCounterClockwiseFronts) {
    Camera cam = makeCamera({0, 0, 3}, {0, 0, 0}, 32, 32);
    Scene s;
    Mesh m;
    m.positions = {{-1, -1, 0}, {1, -1, 0}, {0, 1, 0}};
    m.indices = {0, 1, 2, 0, 2, 1};  // front (CCW seen from +z), then the same triangle reversed
    s.meshes.push_back(m);
    ASSERT_TRUE(s.finalize().isOk());
    auto r = makeRenderer(1);
    FrameBuffers fb;
    fb.resize(32, 32);
    RenderOptions opt;
    opt.cullBackFaces = true;
    r->render(s, cam, opt, fb.targets());
    EXPECT_EQ(fb.id.at(16, 16), 1u);
    std::vector<uint32_t> onlyBack = {1};
    r->renderSubset(s, cam, onlyBack, opt, fb.targets());
    EXPECT_EQ(countDistinctIds(fb.id), 0u);
}

TEST(Raster, RejectsBadConfig) {
    EXPECT_FALSE(Renderer::create({1, 48}).isOk());
    EXPECT_FALSE(Renderer::create({1, 4}).isOk());
    EXPECT_FALSE(Renderer::create({-1, 64}).isOk());
    EXPECT_FALSE(parseShading("phong").isOk());
}

// Golden image: a fixed scene under all three shadings, compared with a committed PNG within a
// tolerance; PLX_UPDATE_GOLDEN=1 rewrites the files, a failure writes a diff image.
TEST_P(RasterPath, GoldenImages) {
    Scene s = randomSoup(60, 2024, true);
    addSphere(&s, {-2.0f, 1.0f, 3.0f}, 1.6f, 12, 24, 1);
    addSphere(&s, {2.5f, 0.5f, 3.0f}, 1.2f, 10, 20, 0);
    ASSERT_TRUE(s.finalize().isOk());
    Camera cam = makeCamera({0.5f, 3.0f, 11.0f}, {0, 0, 0}, 160, 100);
    auto r = makeRenderer(2);
    std::string goldenDir = std::string(PLX_SOURCE_DIR) + "/tests/golden";
    std::string outDir = std::string(PLX_TEST_OUTPUT_DIR);
    std::filesystem::create_directories(outDir);
    for (Shading shading : {Shading::kFlat, Shading::kGouraud, Shading::kTextured}) {
        RenderOptions opt;
        opt.shading = shading;
        FrameBuffers fb;
        fb.resize(160, 100);
        r->render(s, cam, opt, fb.targets());
        std::string name = std::string("raster_") + shadingName(shading) + ".png";
        std::string golden = goldenDir + "/" + name;
        if (std::getenv("PLX_UPDATE_GOLDEN")) {
            ASSERT_TRUE(writePng(golden, fb.color, 9).isOk());
            continue;
        }
        auto expected = readImage(golden);
        ASSERT_TRUE(expected.isOk()) << expected.status().toString();
        Image<Rgba8> want = toRgba8(*expected);
        ImageDiffStats d = compareImages(fb.color, want, 2);
        if (d.differingPixels > 0) {
            (void)writePng(outDir + "/diff_" + name, diffImage(fb.color, want));
            (void)writePng(outDir + "/actual_" + name, fb.color);
        }
        // Tolerance: a few pixels may change with compiler rounding choices on other machines.
        EXPECT_LE(d.differingPixels, 30) << name << " differs; see " << outDir;
        EXPECT_GT(d.psnrDb, 35.0) << name;
    }
}

}  // namespace
}  // namespace plx::raster

namespace plx::raster {
namespace {

TEST_P(RasterPath, ReportsUnsampledTrianglesInFrontOfTheDepth) {
    // fov 90, 8x8, z = -1: world x maps to pixel 4x+4. A wall at z = -2 fills the image; two
    // tiny triangles lie between the sample centres of pixel (3,3): one in front of the wall,
    // one behind it.
    Camera cam = makeCamera({0, 0, 0}, {0, 0, -1}, 8, 8, 90.0f, 0.1f, 100.0f);
    Scene s;
    Mesh wall;
    wall.positions = {{-10, -10, -2}, {10, -10, -2}, {10, 10, -2}, {-10, 10, -2}};
    wall.indices = {0, 1, 2, 0, 2, 3};
    s.meshes.push_back(wall);
    Mesh tiny;
    auto px = [](float p) { return (p - 4.0f) / 4.0f; };
    for (float z : {-1.0f, -3.0f}) {
        float k = -z;  // keep the same pixel footprint at depth z
        uint32_t base = uint32_t(tiny.positions.size());
        tiny.positions.push_back({px(3.1f) * k, -px(3.1f) * k, z});
        tiny.positions.push_back({px(3.3f) * k, -px(3.1f) * k, z});
        tiny.positions.push_back({px(3.1f) * k, -px(3.3f) * k, z});
        tiny.indices.insert(tiny.indices.end(), {base, base + 1, base + 2});
    }
    s.meshes.push_back(tiny);
    ASSERT_TRUE(s.finalize().isOk());
    auto r = makeRenderer(1, 8);
    FrameBuffers fb;
    fb.resize(8, 8);
    std::vector<uint32_t> unsampled;
    RenderTargets targets = fb.targets();
    targets.visibility.unsampledVisible = &unsampled;
    r->render(s, cam, {}, targets);
    EXPECT_EQ(countDistinctIds(fb.id), 2u);  // only the wall's two triangles hit samples
    EXPECT_EQ(unsampled, std::vector<uint32_t>{2});  // the tiny one in front, not the one behind
}

}  // namespace
}  // namespace plx::raster

namespace plx::raster {
namespace {

// A textured tessellated plane (jittered interior vertices: no two triangles overlap) plus,
// when asked, a random soup in front of it (overlapping triangles).
Scene colorOnlyScene(bool overlapping, std::mt19937& rng) {
    Mat4 tilt = glm::rotate(Mat4(1.0f), -0.6f, Vec3(1.0f, 0.0f, 0.0f));
    Scene s = overlapping ? randomSoup(150, 17, true) : Scene{};
    Scene plane = tessellatedPlane(12, 2.5f, tilt, rng);
    for (const Vec3& p : plane.meshes[0].positions)
        plane.meshes[0].uvs.push_back(Vec2(0.4f * p.x + 0.5f, 0.3f * p.y + 0.2f));
    plane.meshes[0].materialIndex = int(s.materials.size());
    s.materials.push_back({"plane", {1.0f, 1.0f, 1.0f, 1.0f}, int(s.textures.size())});
    Image<Rgba8> noise(37, 29);
    std::uniform_int_distribution<int> byte(0, 255);
    for (size_t i = 0; i < noise.pixelCount(); ++i)
        noise.data()[i] = Rgba8{uint8_t(byte(rng)), uint8_t(byte(rng)), uint8_t(byte(rng)), 255};
    scene::Texture tex;
    tex.mips.push_back(noise);
    s.textures.push_back(std::move(tex));
    s.meshes.push_back(std::move(plane.meshes[0]));
    PLX_CHECK(s.finalize().isOk());
    return s;
}

// Colour-only rendering: on a mesh whose triangles never overlap, the colour of the
// depth-tested render; on overlapping ones, the scalar reference's colour-only image (the last
// triangle drawn wins); the depth and ID targets, when passed, stay untouched.
TEST_P(RasterPath, ColorOnlyEqualsDepthTestedColourWithoutOverlap) {
    std::mt19937 rng(5);
    Camera cam = makeCamera({0.2f, 0.3f, 4.5f}, {0.0f, 0.0f, 0.0f}, 157, 103, 60.0f);
    for (bool overlapping : {false, true}) {
        Scene s = colorOnlyScene(overlapping, rng);
        for (Shading shading : {Shading::kFlat, Shading::kGouraud, Shading::kTextured}) {
            std::string what = std::string(shadingName(shading)) +
                               (overlapping ? " overlapping" : " plane");
            RenderOptions opt;
            opt.shading = shading;
            FrameBuffers tested, ref;
            tested.resize(157, 103);
            ref.resize(157, 103);
            auto r = makeRenderer(2, 16);
            r->render(s, cam, opt, tested.targets());
            opt.colorOnly = true;
            renderReference(s, cam, opt, {ref.color.view(), {}, {}, {}});
            if (!overlapping) {
                EXPECT_TRUE(ref.color == tested.color) << what;
            }
            for (int tile : {8, 64}) {
                auto fast = makeRenderer(2, tile);
                FrameBuffers out;
                out.resize(157, 103);
                out.depth.fill(-7.0f);
                out.id.fill(77u);
                fast->render(s, cam, opt, {out.color.view(), {}, {}, {}});
                EXPECT_TRUE(out.color == ref.color) << what << " tile " << tile;
                fast->render(s, cam, opt, out.targets());  // views present but ignored
                EXPECT_TRUE(out.color == ref.color) << what << " tile " << tile;
                EXPECT_EQ(out.depth.at(80, 50), -7.0f);
                EXPECT_EQ(out.id.at(80, 50), 77u);
                if (!overlapping) {
                    EXPECT_TRUE(out.color == tested.color) << what;
                }
            }
            if (overlapping) {
                EXPECT_FALSE(ref.color == tested.color) << what;
            }
        }
    }
}

// Clearing only the tiles drawn into (last frame's and this one's) gives, frame after frame, the
// targets of a whole clear, byte for byte: a small object moving across tiles and out of view,
// frames on other targets in between, a different clear colour, colour-only and depth-tested.
TEST_P(RasterPath, ClearingDrawnTilesOnlyEqualsWholeClear) {
    std::mt19937 rng(9);
    Scene s = colorOnlyScene(false, rng);
    Scene other = randomSoup(60, 3, false);
    for (bool colorOnly : {false, true}) {
        auto tracked = makeRenderer(2, 16);
        auto whole = makeRenderer(1, 64);
        FrameBuffers a, b, side;
        a.resize(140, 96);
        b.resize(140, 96);
        side.resize(140, 96);
        for (int frame = 0; frame < 14; ++frame) {
            float t = float(frame);
            // The viewer moves; the plane drifts across the image and, at frames 6-7, out of it.
            Vec3 eye(-3.0f + 0.9f * t, 0.4f * std::sin(t), 20.0f);
            Vec3 target = (frame == 6 || frame == 7) ? eye + Vec3(0.0f, 0.0f, 1.0f)
                                                     : Vec3(eye.x * 0.2f, 0.0f, 0.0f);
            Camera cam = makeCamera(eye, target, 140, 96, 40.0f);
            RenderOptions opt;
            opt.shading = frame % 3 ? Shading::kTextured : Shading::kFlat;
            opt.colorOnly = colorOnly;
            if (frame >= 10) opt.clearColor = {1, 2, 3, 255};
            whole->render(s, cam, opt, b.targets());
            // Frame 12 follows a frame on the same targets drawn without the option, which is
            // not remembered: it clears everything.
            if (frame == 12) tracked->render(s, cam, opt, a.targets());
            opt.clearDrawnTilesOnly = true;
            RenderStats st = tracked->render(s, cam, opt, a.targets());
            std::string what = std::string(colorOnly ? "colour only" : "depth tested") +
                               " frame " + std::to_string(frame);
            EXPECT_TRUE(a.color == b.color) << what;
            if (!colorOnly) {
                EXPECT_TRUE(a.depth == b.depth) << what;
                EXPECT_TRUE(a.id == b.id) << what;
            }
            if (frame == 6) {
                EXPECT_EQ(st.trianglesBinned, 0u) << "the plane is out of view";
            }
            // Frame 0 and the first of a new clear colour clear everything; frame 7 follows an
            // empty frame and draws nothing, so it clears no tile.
            if (frame == 0 || frame == 10 || frame == 12) {
                EXPECT_EQ(st.tilesCleared, 9u * 6u) << what;
            }
            if (frame == 7) {
                EXPECT_EQ(st.tilesCleared, 0u) << what;
            }
            if (frame == 3 || frame == 11 || frame == 13) {
                EXPECT_LT(st.tilesCleared, 9u * 6u) << what;
            }
            if (frame % 4 == 2) tracked->render(other, cam, {}, side.targets());
        }
    }
}

// Records the distinct IDs of every tile it is shown.
class IdSetVisitor : public TileIdVisitor {
public:
    void visitTile(const ImageView<uint32_t>& ids, int x0, int y0, int x1, int y1, int) override {
        std::lock_guard lock(mMutex);
        for (int y = y0; y <= y1; ++y)
            for (int x = x0; x <= x1; ++x)
                if (ids.row(y)[x]) mIds.insert(ids.row(y)[x]);
    }
    std::set<uint32_t> take() { return std::exchange(mIds, {}); }

private:
    std::mutex mMutex;
    std::set<uint32_t> mIds;
};

// A render may leave out its depth or ID target (or both): the depth test runs in tile memory,
// also for tiles too large to keep there otherwise (256), and the planes written equal those of
// a complete render; the tile visitor still sees every ID; the reference renderer agrees.
TEST_P(RasterPath, DepthAndIdsLeftOutChangeNothingElse) {
    Scene s = randomSoup(400, 5, true);
    Camera cam = makeCamera({0.5f, 1, 9}, {0, 0, 0}, 150, 90);
    std::vector<uint32_t> some;
    for (uint32_t i = 0; i < s.triangleCount(); i += 2) some.push_back(i);
    std::span<const uint32_t> someSpan(some);
    FrameBuffers whole, part, ref;
    whole.resize(150, 90);
    ref.resize(150, 90);
    IdSetVisitor visitor;
    for (int tileSize : {16, 256}) {
        for (int threads : {1, 2}) {
            auto r = makeRenderer(threads, tileSize);
            for (int frame = 0; frame < 6; ++frame) {
                const bool subset = frame % 2 == 1;
                const bool keepDepth = frame / 2 == 1, keepIds = frame / 2 == 2;
                RenderOptions opt;
                opt.shading = Shading::kTextured;
                opt.clearDrawnTilesOnly = frame == 5;
                if (subset)
                    r->renderSubset(s, cam, some, opt, whole.targets());
                else
                    r->render(s, cam, opt, whole.targets());
                part.resize(150, 90);  // fresh planes: nothing may be left from `whole`
                RenderTargets t = part.targets();
                if (!keepDepth) t.depth = {};
                if (!keepIds) t.id = {};
                t.visibility.tileIds = &visitor;
                if (subset)
                    r->renderSubset(s, cam, some, opt, t);
                else
                    r->render(s, cam, opt, t);
                const std::string what = "tile " + std::to_string(tileSize) + ", threads " +
                                         std::to_string(threads) + ", frame " +
                                         std::to_string(frame);
                EXPECT_TRUE(part.color == whole.color) << what;
                if (keepDepth) {
                    EXPECT_TRUE(part.depth == whole.depth) << what;
                }
                if (keepIds) {
                    EXPECT_TRUE(part.id == whole.id) << what;
                }
                std::set<uint32_t> drawn(whole.id.data(), whole.id.data() + whole.id.pixelCount());
                drawn.erase(0u);
                EXPECT_EQ(visitor.take(), drawn) << what;
            }
        }
    }
    RenderOptions opt;
    opt.shading = Shading::kTextured;
    renderReference(s, cam, opt, ref.targets(), &someSpan);
    part.resize(150, 90);
    renderReference(s, cam, opt, {part.color.view(), {}, {}, {}}, &someSpan);
    EXPECT_TRUE(part.color == ref.color) << "reference renderer";
}

TEST(Raster, RejectsMalformedRenderRequests) {
    Camera cam = makeCamera({0, 0, 3}, {0, 0, 0}, 32, 24);
    FrameBuffers fb, small;
    fb.resize(32, 24);
    small.resize(16, 24);
    Image<float> depth2(32, 24);
    Image<uint32_t> id2(32, 24);
    std::vector<uint32_t> unsampled;
    RenderOptions colorOnly;
    colorOnly.colorOnly = true;
    EXPECT_TRUE(checkRenderRequest(cam, {}, fb.targets()).isOk());
    EXPECT_TRUE(checkRenderRequest(cam, colorOnly, {fb.color.view(), {}, {}, {}}).isOk());
    auto message = [&](const RenderOptions& o, const RenderTargets& t) {
        Status st = checkRenderRequest(cam, o, t);
        EXPECT_EQ(st.code(), ErrorCode::kInvalidArgument);
        return st.message();
    };
    EXPECT_NE(message(colorOnly, {{}, fb.depth.view(), fb.id.view(), {}})
                  .find("needs a colour target"),
              std::string::npos);
    RenderOptions unknownShading;
    unknownShading.shading = Shading(3);
    EXPECT_EQ(message(unknownShading, fb.targets()), "unknown shading");
    EXPECT_NE(message(colorOnly,
                      {fb.color.view(), fb.depth.view(), fb.id.view(), {depth2.view(), id2.view()}})
                  .find("second depth layer"),
              std::string::npos);
    RenderTargets withUnsampled = fb.targets();
    withUnsampled.visibility.unsampledVisible = &unsampled;
    EXPECT_NE(message(colorOnly, withUnsampled).find("unsampled"), std::string::npos);
    IdSetVisitor visitor;
    RenderTargets withTileIds = fb.targets();
    withTileIds.visibility.tileIds = &visitor;
    EXPECT_NE(message(colorOnly, withTileIds).find("no ID target to visit"), std::string::npos);
    EXPECT_TRUE(checkRenderRequest(cam, {}, {fb.color.view(), {}, {}, {}}).isOk());
    EXPECT_TRUE(checkRenderRequest(cam, {}, {{}, {}, fb.id.view(), {}}).isOk());
    RenderOptions keep;
    keep.clearTargets = false;
    EXPECT_NE(message(keep, {fb.color.view(), fb.depth.view(), {}, {}}).find("keeps its"),
              std::string::npos);
    EXPECT_NE(message({}, {fb.color.view(), {}, fb.id.view(), {depth2.view(), id2.view()}})
                  .find("second depth layer needs depth and ID"),
              std::string::npos);
    EXPECT_NE(message({}, {fb.color.view(), {}, fb.id.view(), {{}, {}, &unsampled}})
                  .find("needs a depth target"),
              std::string::npos);
    EXPECT_NE(message({}, small.targets()).find("size differs"), std::string::npos);
    EXPECT_NE(message({}, {fb.color.view(), fb.depth.view(), fb.id.view(), {depth2.view(), {}}})
                  .find("both"),
              std::string::npos);
    // Row strides below the width (rows overlapping, or running backwards over the data).
    for (ptrdiff_t stride : {ptrdiff_t(31), ptrdiff_t(0), ptrdiff_t(-32)}) {
        RenderTargets overlapping = fb.targets();
        overlapping.id.strideElems = stride;
        EXPECT_NE(message({}, overlapping).find("row stride"), std::string::npos) << stride;
    }
    RenderTargets secondLayer = fb.targets();
    secondLayer.visibility = {depth2.view(), id2.view()};
    secondLayer.visibility.depth2.strideElems = 1;
    EXPECT_NE(message({}, secondLayer).find("row stride"), std::string::npos);
}

}  // namespace
}  // namespace plx::raster
