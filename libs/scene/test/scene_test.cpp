#include <gtest/gtest.h>

#include <plx/scene/scene.h>

namespace plx::scene {
namespace {

Scene oneTriangle() {
    Scene s;
    Mesh m;
    m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    m.indices = {0, 1, 2};
    s.meshes.push_back(m);
    return s;
}

TEST(Scene, FinalizeComputesOffsetsNormalsAndBounds) {
    Scene s = oneTriangle();
    s.meshes.push_back(s.meshes[0]);
    ASSERT_TRUE(s.finalize().isOk());
    EXPECT_EQ(s.triangleCount(), 2u);
    EXPECT_EQ(s.firstTriangle(1), 1u);
    EXPECT_EQ(s.meshOfTriangle(0), 0u);
    EXPECT_EQ(s.meshOfTriangle(1), 1u);
    EXPECT_NEAR(s.meshes[0].normals[0].z, 1.0f, 1e-6f);
    EXPECT_EQ(s.materials.size(), 1u);
    EXPECT_EQ(s.bounds().hi, Vec3(1, 1, 0));
}

TEST(Scene, FinalizeComputesFaceNormalsPerGlobalTriangle) {
    Scene s = oneTriangle();
    Mesh second = s.meshes[0];
    second.indices = {0, 2, 1, 0, 1, 1};  // clockwise in the xy plane, then degenerate
    s.meshes.push_back(second);
    ASSERT_TRUE(s.finalize().isOk());
    EXPECT_EQ(s.faceNormal(0), Vec3(0, 0, 1));
    EXPECT_EQ(s.faceNormal(1), Vec3(0, 0, -1));
    EXPECT_EQ(s.faceNormal(2), Vec3(0, 1, 0));  // no plane: the documented fallback
    // Editing the arrays and finalising again recomputes them.
    s.meshes[0].positions[2] = {0, 0, 2};
    ASSERT_TRUE(s.finalize().isOk());
    EXPECT_EQ(s.faceNormal(0), Vec3(0, -1, 0));
    EXPECT_EQ(s.faceNormal(1), Vec3(0, 0, -1));
}

TEST(Scene, FinalizeRejectsBadGeometry) {
    Scene s = oneTriangle();
    s.meshes[0].positions[1].x = std::numeric_limits<float>::quiet_NaN();
    EXPECT_NE(s.finalize().message().find("non-finite"), std::string::npos);
    s = oneTriangle();
    s.meshes[0].positions[1] = {0, 0, -2e15f};  // beyond kMaxCameraCoordinate
    EXPECT_NE(s.finalize().message().find("vertex 1 at (0, 0, -2e+15) lies beyond +-1e+15"),
              std::string::npos)
        << s.finalize().message();
    s = oneTriangle();
    s.meshes[0].indices[2] = 9;
    EXPECT_NE(s.finalize().message().find("out of range"), std::string::npos);
    s = oneTriangle();
    s.meshes[0].indices.clear();
    EXPECT_NE(s.finalize().message().find("no triangles"), std::string::npos);
    s = oneTriangle();
    s.meshes[0].materialIndex = 3;
    EXPECT_FALSE(s.finalize().isOk());
}

// Viewpoints and rooms become cameras; colours are drawn: none may be NaN or out of range.
TEST(Scene, FinalizeRejectsWhatCouldNotBeFramedOrDrawn) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    Scene s = oneTriangle();
    s.viewpoints.push_back({"door", {0, 0, 3}, {nan, 0, 0}});
    EXPECT_NE(s.finalize().message().find("viewpoint 'door'"), std::string::npos);
    s = oneTriangle();
    s.rooms.push_back(Aabb{{-1e30f, 0, 0}, {1, 1, 1}});
    EXPECT_NE(s.finalize().message().find("room 0 is not a finite box"), std::string::npos);
    s = oneTriangle();
    s.rooms.push_back(Aabb{});  // empty
    EXPECT_FALSE(s.finalize().isOk());
    s = oneTriangle();
    s.materials.push_back(Material{"m", {0.5f, 0.5f, 0.5f, nan}, -1});
    EXPECT_NE(s.finalize().message().find("material 0 has a non-finite colour"), std::string::npos);
    s = oneTriangle();
    s.viewpoints.push_back({"door", {0, 0, 3}});
    s.rooms.push_back(Aabb{{0, 0, 0}, {1, 1, 1}});
    EXPECT_TRUE(s.finalize().isOk());
}

TEST(Scene, MipChainHalvesDownToOnePixel) {
    Texture t;
    t.mips.emplace_back(5, 3, Rgba8{255, 0, 0, 255});
    buildMipChain(&t);
    ASSERT_EQ(t.mips.size(), 4u);  // 5x3, 3x2, 2x1, 1x1
    EXPECT_EQ(t.mips[1].width(), 3);
    EXPECT_EQ(t.mips[1].height(), 2);
    EXPECT_EQ(t.mips[3].width(), 1);
    EXPECT_EQ(t.mips[3].at(0, 0), (Rgba8{255, 0, 0, 255}));
}

}  // namespace
}  // namespace plx::scene
