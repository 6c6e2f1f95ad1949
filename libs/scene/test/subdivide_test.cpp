#include <gtest/gtest.h>

#include <plx/scene/generators.h>
#include <plx/scene/subdivide.h>

namespace plx::scene {
namespace {

// Two triangles sharing an edge, with normals and UVs.
Scene quad() {
    Scene s;
    Mesh m;
    m.positions = {{0, 0, 0}, {2, 0, 0}, {2, 2, 0}, {0, 2, 0}};
    m.normals = {{0, 0, 1}, {0, 0, 1}, {1, 0, 0}, {0, 0, 1}};
    m.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    m.indices = {0, 1, 2, 0, 2, 3};
    s.meshes.push_back(m);
    PLX_CHECK(s.finalize().isOk());
    return s;
}

TEST(Subdivide, QuadruplesTrianglesAndSharesEdgeMidpoints) {
    Scene s = quad();
    auto once = subdivideMidpoint(s, 1);
    ASSERT_TRUE(once.isOk()) << once.status().toString();
    const Mesh& m = once->meshes[0];
    EXPECT_EQ(once->triangleCount(), 8u);
    // 4 corners + 5 edges (the diagonal shared), each midpoint created once.
    EXPECT_EQ(m.positions.size(), 9u);
    EXPECT_EQ(m.normals.size(), 9u);
    EXPECT_EQ(m.uvs.size(), 9u);
    // Triangle 0 -> (a, ab, ca): ab halfway between (0,0,0) and (2,0,0), UV and normal too.
    EXPECT_EQ(m.positions[m.indices[1]], Vec3(1, 0, 0));
    EXPECT_EQ(m.uvs[m.indices[1]], Vec2(0.5f, 0.0f));
    // Midpoint of (2,0,0)-(2,2,0): normals (0,0,1) and (1,0,0) average and renormalise.
    Vec3 n = m.normals[m.indices[5]];
    EXPECT_NEAR(glm::length(n), 1.0f, 1e-6f);
    EXPECT_NEAR(n.x, std::sqrt(0.5f), 1e-6f);
    EXPECT_EQ(once->bounds().lo, s.bounds().lo);
    EXPECT_EQ(once->bounds().hi, s.bounds().hi);
}

TEST(Subdivide, KeepsWindingAndArea) {
    Scene s = quad();
    auto twice = subdivideMidpoint(s, 2);
    ASSERT_TRUE(twice.isOk());
    const Mesh& m = twice->meshes[0];
    ASSERT_EQ(twice->triangleCount(), 32u);
    float area = 0.0f;
    for (size_t t = 0; t < m.indices.size(); t += 3) {
        Vec3 a = m.positions[m.indices[t]], b = m.positions[m.indices[t + 1]],
             c = m.positions[m.indices[t + 2]];
        Vec3 cross = glm::cross(b - a, c - a);
        EXPECT_GT(cross.z, 0.0f) << "triangle " << t / 3 << " flipped";
        area += 0.5f * cross.z;
    }
    EXPECT_FLOAT_EQ(area, 4.0f);
}

TEST(Subdivide, GeneratedSceneKeepsBoundsMaterialsAndViewpoints) {
    auto office = generateOffice(1);
    ASSERT_TRUE(office.isOk());
    for (int levels = 0; levels <= 2; ++levels) {
        auto dense = subdivideMidpoint(*office, levels);
        ASSERT_TRUE(dense.isOk()) << dense.status().toString();
        EXPECT_EQ(dense->triangleCount(), office->triangleCount() << (2 * levels));
        EXPECT_EQ(dense->meshes.size(), office->meshes.size());
        EXPECT_EQ(dense->materials.size(), office->materials.size());
        EXPECT_EQ(dense->viewpoints.size(), office->viewpoints.size());
        EXPECT_EQ(dense->bounds().lo, office->bounds().lo);
        EXPECT_EQ(dense->bounds().hi, office->bounds().hi);
        for (size_t m = 0; m < office->meshes.size(); ++m) {
            EXPECT_EQ(dense->firstTriangle(m), office->firstTriangle(m) << (2 * levels));
        }
    }
}

TEST(Subdivide, RejectsBadArguments) {
    Scene s = quad();
    EXPECT_EQ(subdivideMidpoint(s, -1).status().code(), ErrorCode::kInvalidArgument);
    EXPECT_EQ(subdivideMidpoint(s, kMaxSubdivisionLevels + 1).status().code(),
              ErrorCode::kInvalidArgument);
    auto office = generateOffice(64);  // 232k triangles: 8 levels would exceed the limit
    ASSERT_TRUE(office.isOk());
    auto huge = subdivideMidpoint(*office, kMaxSubdivisionLevels);
    EXPECT_EQ(huge.status().code(), ErrorCode::kOutOfRange);
    EXPECT_NE(huge.status().message().find("over the limit"), std::string::npos);
    s.meshes[0].indices[4] = 17;
    auto bad = subdivideMidpoint(s, 1);
    EXPECT_NE(bad.status().message().find("out of range"), std::string::npos);
}

}  // namespace
}  // namespace plx::scene
