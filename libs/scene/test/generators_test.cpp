#include <gtest/gtest.h>

#include <plx/scene/generators.h>
#include <plx/scene/import.h>
#include <plx/scene/primitives.h>

namespace plx::scene {
namespace {

Vec3 faceNormal(const Mesh& m, size_t t) {
    const Vec3& a = m.positions[m.indices[3 * t]];
    const Vec3& b = m.positions[m.indices[3 * t + 1]];
    const Vec3& c = m.positions[m.indices[3 * t + 2]];
    return glm::cross(b - a, c - a);
}

Vec3 centroid(const Mesh& m, size_t t) {
    return (m.positions[m.indices[3 * t]] + m.positions[m.indices[3 * t + 1]] +
            m.positions[m.indices[3 * t + 2]]) /
           3.0f;
}

// Every triangle's winding (counter-clockwise from the front) agrees with its vertex normals.
void expectWindingMatchesNormals(const Scene& s) {
    size_t bad = 0;
    for (const Mesh& m : s.meshes)
        for (size_t t = 0; t < m.triangleCount(); ++t) {
            Vec3 n = faceNormal(m, t);
            for (int k = 0; k < 3; ++k)
                if (glm::dot(n, m.normals[m.indices[3 * t + k]]) <= 0.0f) ++bad;
        }
    EXPECT_EQ(bad, 0u);
}

TEST(Primitives, BoxFacesPointAwayFromTheCentre) {
    Mesh m;
    Vec3 centre(1, 2, 3);
    appendBox(&m, centre, {0.5f, 1.0f, 2.0f}, 0.7f);
    ASSERT_EQ(m.triangleCount(), 12u);
    for (size_t t = 0; t < m.triangleCount(); ++t) {
        Vec3 n = faceNormal(m, t);
        EXPECT_GT(glm::dot(n, centroid(m, t) - centre), 0.0f) << "triangle " << t;
        EXPECT_GT(glm::dot(n, m.normals[m.indices[3 * t]]), 0.0f);
    }
}

TEST(Primitives, CylinderFacesPointAwayFromTheAxis) {
    Mesh m;
    Vec3 base(0, 1, 0);
    appendCylinder(&m, base, 0.5f, 2.0f, 12);
    ASSERT_EQ(m.triangleCount(), 48u);
    Vec3 centre = base + Vec3(0, 1, 0);
    for (size_t t = 0; t < m.triangleCount(); ++t) {
        EXPECT_GT(glm::dot(faceNormal(m, t), centroid(m, t) - centre), 0.0f) << "triangle " << t;
        EXPECT_GT(glm::dot(faceNormal(m, t), m.normals[m.indices[3 * t]]), 0.0f);
    }
}

TEST(Office, OneRoomHasAboutThePapersPolygonCount) {
    auto s = generateOffice(1);
    ASSERT_TRUE(s.isOk()) << s.status().message();
    // The paper's room has 3652 polygons (Table 1).
    EXPECT_GE(s->triangleCount(), 3600u);
    EXPECT_LE(s->triangleCount(), 3700u);
    EXPECT_GE(s->materials.size(), 6u);
    EXPECT_TRUE(s->textures.empty());
    expectWindingMatchesNormals(*s);
}

TEST(Office, RoomsAreExactCopiesOnAGrowingGrid) {
    auto one = generateOffice(1);
    ASSERT_TRUE(one.isOk());
    Aabb previous = one->bounds();
    for (int n : {2, 4, 5, 15}) {
        auto s = generateOffice(n);
        ASSERT_TRUE(s.isOk()) << s.status().message();
        EXPECT_EQ(s->triangleCount(), size_t(n) * one->triangleCount());
        Aabb b = s->bounds();
        EXPECT_GE(b.extent().x * b.extent().z, previous.extent().x * previous.extent().z);
        EXPECT_FLOAT_EQ(b.extent().y, one->bounds().extent().y);
        previous = b;
    }
    auto fifteen = generateOffice(15);
    // ceil(sqrt(15)) = 4 columns of 8 m rooms.
    EXPECT_NEAR(fifteen->bounds().hi.x, 32.0f, 1e-3f);
}

TEST(Office, IsDeterministic) {
    auto a = generateOffice(3), b = generateOffice(3);
    ASSERT_TRUE(a.isOk() && b.isOk());
    ASSERT_EQ(a->meshes.size(), b->meshes.size());
    for (size_t m = 0; m < a->meshes.size(); ++m) {
        EXPECT_EQ(a->meshes[m].positions, b->meshes[m].positions);
        EXPECT_EQ(a->meshes[m].indices, b->meshes[m].indices);
    }
}

TEST(Office, ViewpointsStandInsideTheFirstRoomAndAbove) {
    auto s = generateOffice(4);
    ASSERT_TRUE(s.isOk());
    ASSERT_EQ(s->viewpoints.size(), 3u);
    // "default" and "vista" stand in the corner room and look diagonally across the grid; the
    // default looks down far enough that the top of its view stays below the horizon.
    for (int i = 0; i < 2; ++i) {
        const Viewpoint& v = s->viewpoints[size_t(i)];
        EXPECT_EQ(v.name, i == 0 ? "default" : "vista");
        EXPECT_NEAR(v.eyePos.y, 1.6f, 0.2f);
        EXPECT_LT(v.eyePos.x, 8.0f);
        EXPECT_LT(v.eyePos.z, 8.0f);
        Vec3 dir = glm::normalize(v.targetPos - v.eyePos);
        EXPECT_GT(dir.x, 0.0f);
        EXPECT_GT(dir.z, 0.0f);
        float pitch = std::asin(-dir.y) * 180.0f / kPi;
        if (i == 0) EXPECT_GT(pitch - 0.5f * v.fovYDegrees, 0.0f);  // top edge below horizon
        else EXPECT_LT(pitch - 0.5f * v.fovYDegrees, 0.0f);        // horizon in view
    }
    EXPECT_EQ(s->viewpoints[2].name, "overview");
    EXPECT_GT(s->viewpoints[2].eyePos.y, s->bounds().hi.y);
}

TEST(Museum, HasTexturedRoomsWithMipChains) {
    auto s = generateMuseum(3);
    ASSERT_TRUE(s.isOk()) << s.status().message();
    // Floor, walls and one texture per painting (four per room).
    EXPECT_EQ(s->textures.size(), 2u + 12u);
    for (const Texture& t : s->textures) {
        ASSERT_FALSE(t.mips.empty());
        EXPECT_GE(t.width(), 256);
        EXPECT_EQ(t.mips.back().width(), 1);
        EXPECT_EQ(t.mips.back().height(), 1);
    }
    // Paintings differ from one another.
    EXPECT_FALSE(s->textures[2].mips[0] == s->textures[3].mips[0]);
    for (const Mesh& m : s->meshes) EXPECT_EQ(m.uvs.size(), m.positions.size());
    expectWindingMatchesNormals(*s);
    ASSERT_FALSE(s->viewpoints.empty());
    EXPECT_EQ(s->viewpoints[0].name, "default");
    // The default eye stands in room 0 (x, z in [0, 10]).
    EXPECT_LT(s->viewpoints[0].eyePos.x, 10.0f);
}

TEST(Museum, IsDeterministicAndGrows) {
    auto a = generateMuseum(2), b = generateMuseum(2), c = generateMuseum(5);
    ASSERT_TRUE(a.isOk() && b.isOk() && c.isOk());
    EXPECT_EQ(a->triangleCount(), b->triangleCount());
    for (size_t t = 0; t < a->textures.size(); ++t)
        EXPECT_TRUE(a->textures[t].mips[0] == b->textures[t].mips[0]);
    EXPECT_GT(c->triangleCount(), a->triangleCount());
    EXPECT_GT(c->bounds().extent().z, a->bounds().extent().z);
}

TEST(Showcase, IsAPedestalAndAFigureOnTheVerticalAxis) {
    auto s = generateShowcase();
    ASSERT_TRUE(s.isOk()) << s.status().toString();
    ASSERT_EQ(s->meshes.size(), 2u);
    // Box 12, spheres 2 * (16 * 24 + 12 * 18 + 10 * 14).
    EXPECT_EQ(s->meshes[0].triangleCount(), 12u);
    EXPECT_EQ(s->triangleCount(), 1492u);
    EXPECT_EQ(s->materials.size(), 2u);
    EXPECT_TRUE(s->textures.empty());
    const Aabb& b = s->bounds();
    EXPECT_NEAR(b.lo.y, -0.40f, 1e-5f);
    EXPECT_NEAR(b.hi.y, 0.29f, 1e-5f);
    EXPECT_NEAR(b.lo.x, -0.12f, 1e-5f);  // the pedestal and the body are 0.24 wide
    EXPECT_NEAR(b.hi.x, 0.12f, 1e-5f);
    ASSERT_EQ(s->viewpoints.size(), 1u);
    EXPECT_EQ(s->viewpoints[0].name, "default");
    // The pedestal's faces point away from its centre.
    const Mesh& pedestal = s->meshes[0];
    for (size_t t = 0; t < pedestal.triangleCount(); ++t)
        EXPECT_GT(glm::dot(faceNormal(pedestal, t), centroid(pedestal, t) - Vec3(0, -0.35f, 0)),
                  0.0f)
            << "triangle " << t;
}

TEST(Showcase, IsABareSpecAndDeterministic) {
    EXPECT_TRUE(isGeneratorSpec("showcase"));
    EXPECT_FALSE(isGeneratorSpec("showcases"));
    auto a = loadScene("showcase");
    auto b = generateShowcase();
    ASSERT_TRUE(a.isOk()) << a.status().toString();
    ASSERT_TRUE(b.isOk());
    ASSERT_EQ(a->meshes.size(), b->meshes.size());
    for (size_t m = 0; m < a->meshes.size(); ++m) {
        EXPECT_EQ(a->meshes[m].positions, b->meshes[m].positions);
        EXPECT_EQ(a->meshes[m].indices, b->meshes[m].indices);
    }
    auto counted = generateFromSpec("showcase:2");
    ASSERT_FALSE(counted.isOk());
    EXPECT_NE(counted.status().message().find("takes no count"), std::string::npos);
}

TEST(GeneratorSpec, ParsesCountsAndRejectsBadOnes) {
    auto s = generateFromSpec("office:2");
    ASSERT_TRUE(s.isOk());
    EXPECT_EQ(s->triangleCount(), 2 * generateOffice(1)->triangleCount());
    for (const char* bad : {"office:0", "office:x", "office:-1", "office:99999999", "office:",
                            "office:2x", "museum:0", "museum:100000"}) {
        auto r = generateFromSpec(bad);
        ASSERT_FALSE(r.isOk()) << bad;
        EXPECT_NE(r.status().message().find("room count"), std::string::npos) << bad;
    }
    auto unknown = loadScene("foo:3");
    ASSERT_FALSE(unknown.isOk());
    EXPECT_NE(unknown.status().message().find("unknown scene generator 'foo'"),
              std::string::npos)
        << unknown.status().message();
    EXPECT_TRUE(isGeneratorSpec("office:4"));
    EXPECT_FALSE(isGeneratorSpec("models/a.obj"));
    EXPECT_FALSE(isGeneratorSpec("C:\\models\\a.obj"));
}

TEST(GeneratorSpec, TriangleBoundsHoldWithoutGenerating) {
    for (const char* spec : {"office:1", "office:7", "office:30", "museum:1", "museum:5",
                             "museum:16", "museum:40", "showcase"}) {
        auto scene = generateFromSpec(spec);
        auto bound = generatedTriangleBound(spec);
        ASSERT_TRUE(scene.isOk() && bound.isOk()) << spec;
        EXPECT_GE(*bound, scene->triangleCount()) << spec;
        // Close: a memory check from it refuses no more than it must.
        EXPECT_LE(double(*bound), 1.1 * double(scene->triangleCount())) << spec;
    }
    EXPECT_EQ(*generatedTriangleBound("office:30"), generateOffice(30)->triangleCount());
    // The largest specs, counted at once.
    EXPECT_EQ(*generatedTriangleBound("office:4096"), 4096 * generateOffice(1)->triangleCount());
    EXPECT_EQ(*generatedTriangleBound("museum:1024"), 1024 * generateMuseum(1)->triangleCount());
    for (const char* bad : {"office:0", "museum:100000", "foo:3", "showcase:2"})
        EXPECT_FALSE(generatedTriangleBound(bad).isOk()) << bad;
}

}  // namespace
}  // namespace plx::scene
