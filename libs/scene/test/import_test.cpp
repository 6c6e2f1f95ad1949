#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include <plx/scene/import.h>

#include "expect_import_error.h"

namespace plx::scene {
namespace {

namespace fs = std::filesystem;

std::string fixture(const std::string& name) {
    return std::string(PLX_SOURCE_DIR) + "/libs/scene/test/fixtures/" + name;
}

// A fresh folder for the files one test writes.
fs::path tempDir(const std::string& name) {
    fs::path dir = fs::path(PLX_TEST_OUTPUT_DIR) / "scene_import" / name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

std::string writeFile(const fs::path& dir, const std::string& name, const std::string& bytes) {
    fs::path p = dir / name;
    std::ofstream(p, std::ios::binary) << bytes;
    return p.string();
}

std::string readText(const std::string& path) {
    auto bytes = readFileBytes(path);
    return bytes ? std::string(bytes->begin(), bytes->end()) : std::string();
}

// Each triangle's winding agrees with its vertex normals.
void expectNormalsMatchWinding(const Scene& s) {
    for (const Mesh& m : s.meshes) {
        ASSERT_EQ(m.normals.size(), m.positions.size());
        for (size_t t = 0; t < m.triangleCount(); ++t) {
            const Vec3& a = m.positions[m.indices[3 * t]];
            Vec3 n = glm::cross(m.positions[m.indices[3 * t + 1]] - a,
                                m.positions[m.indices[3 * t + 2]] - a);
            for (int k = 0; k < 3; ++k) {
                const Vec3& vn = m.normals[m.indices[3 * t + k]];
                EXPECT_NEAR(glm::length(vn), 1.0f, 1e-4f);
                EXPECT_GT(glm::dot(n, vn), 0.0f) << m.name << " triangle " << t;
            }
        }
    }
}

TEST(Import, ObjWithMtlAndExternalTexture) {
    auto s = importFile(fixture("tiny.obj"));
    ASSERT_TRUE(s.isOk()) << s.status().message();
    EXPECT_EQ(s->triangleCount(), 3u);
    EXPECT_EQ(s->degenerateTrianglesDropped, 2u);
    expectNormalsMatchWinding(*s);
    EXPECT_NEAR(s->meshes[0].normals[0].z, 1.0f, 1e-5f);
    EXPECT_EQ(s->meshes[0].uvs.size(), s->meshes[0].positions.size());
    const Material& mat = s->materials[size_t(s->meshes[0].materialIndex)];
    EXPECT_NEAR(mat.baseColor.r, 0.2f, 1e-5f);
    EXPECT_NEAR(mat.baseColor.g, 0.4f, 1e-5f);
    EXPECT_NEAR(mat.baseColor.b, 0.6f, 1e-5f);
    ASSERT_EQ(mat.baseColorTexture, 0);
    const Texture& tex = s->textures[0];
    EXPECT_EQ(tex.width(), 2);
    EXPECT_EQ(tex.height(), 2);
    EXPECT_EQ(tex.mips.size(), 2u);
    EXPECT_EQ(tex.mips[0].at(0, 0), (Rgba8{255, 0, 0, 255}));  // the PNG's top-left texel
    EXPECT_EQ(s->texturesMissing, 0u);
}

TEST(Import, MissingExternalTextureFallsBackToTheBaseColour) {
    fs::path dir = tempDir("missing_texture");
    writeFile(dir, "tiny.obj", readText(fixture("tiny.obj")));
    writeFile(dir, "tiny.mtl", readText(fixture("tiny.mtl")));  // tiny.png not copied
    auto s = importFile((dir / "tiny.obj").string());
    ASSERT_TRUE(s.isOk()) << s.status().message();
    EXPECT_EQ(s->texturesMissing, 1u);
    EXPECT_EQ(s->stats().texturesMissing, 1u);
    EXPECT_TRUE(s->textures.empty());
    EXPECT_EQ(s->materials[size_t(s->meshes[0].materialIndex)].baseColorTexture, -1);
}

TEST(Import, AsciiPlyGetsSmoothNormalsAndNoUvs) {
    auto s = importFile(fixture("pyramid.ply"));
    ASSERT_TRUE(s.isOk()) << s.status().message();
    EXPECT_EQ(s->triangleCount(), 6u);
    EXPECT_EQ(s->degenerateTrianglesDropped, 0u);
    expectNormalsMatchWinding(*s);
    EXPECT_TRUE(s->meshes[0].uvs.empty());
    EXPECT_EQ(s->bounds().hi, Vec3(1, 1, 1));
}

TEST(Import, GltfWithEmbeddedBufferTextureAndCamera) {
    auto s = importFile(fixture("quad_camera.gltf"));
    ASSERT_TRUE(s.isOk()) << s.status().message();
    EXPECT_EQ(s->triangleCount(), 2u);
    expectNormalsMatchWinding(*s);
    // The node's translation is baked into the vertices.
    EXPECT_NEAR(s->bounds().lo.x, 10.0f, 1e-5f);
    EXPECT_NEAR(s->bounds().hi.x, 11.0f, 1e-5f);
    const Mesh& m = s->meshes[0];
    ASSERT_EQ(m.uvs.size(), m.positions.size());
    for (size_t v = 0; v < m.positions.size(); ++v) {
        // glTF UVs are kept as written: v = 0 at the top (y = 1) of the quad.
        EXPECT_NEAR(m.uvs[v].x, m.positions[v].x - 10.0f, 1e-5f);
        EXPECT_NEAR(m.uvs[v].y, 1.0f - m.positions[v].y, 1e-5f);
    }
    const Material& mat = s->materials[size_t(m.materialIndex)];
    EXPECT_NEAR(mat.baseColor.r, 0.5f, 1e-5f);
    EXPECT_NEAR(mat.baseColor.g, 0.25f, 1e-5f);
    EXPECT_NEAR(mat.baseColor.b, 1.0f, 1e-5f);
    ASSERT_GE(mat.baseColorTexture, 0);
    const Texture& tex = s->textures[size_t(mat.baseColorTexture)];
    EXPECT_EQ(tex.width(), 4);
    EXPECT_EQ(tex.height(), 2);
    EXPECT_EQ(tex.mips.size(), 3u);
    EXPECT_EQ(tex.mips[0].at(0, 0), (Rgba8{255, 0, 0, 255}));
    ASSERT_EQ(s->viewpoints.size(), 1u);
    const Viewpoint& v = s->viewpoints[0];
    EXPECT_EQ(v.name, "cam");
    EXPECT_NEAR(glm::length(v.eyePos - Vec3(0, 1, 5)), 0.0f, 1e-5f);
    EXPECT_NEAR(glm::length(glm::normalize(v.targetPos - v.eyePos) - Vec3(0, 0, -1)), 0.0f,
                1e-5f);
    EXPECT_NEAR(glm::length(v.upDir - Vec3(0, 1, 0)), 0.0f, 1e-5f);
    EXPECT_NEAR(v.fovYDegrees, degrees(0.8f), 0.01f);
}

TEST(Import, DamagedHelmet) {
    std::string path = std::string(PLX_SHARED_DATA_DIR) + "/models/DamagedHelmet/DamagedHelmet.glb";
    if (!fs::exists(path)) GTEST_SKIP() << "shared data absent: " << path;
    auto s = importFile(path);
    ASSERT_TRUE(s.isOk()) << s.status().message();
    // 46,356 indices: 15,452 triangles.
    EXPECT_EQ(s->triangleCount(), 15452u);
    ASSERT_FALSE(s->textures.empty());
    EXPECT_GE(s->textures[0].width(), 1024);
    EXPECT_EQ(s->texturesMissing, 0u);
    EXPECT_EQ(s->meshes[0].uvs.size(), s->meshes[0].positions.size());
    int textured = 0;
    for (const Material& m : s->materials) textured += m.baseColorTexture >= 0;
    EXPECT_GE(textured, 1);
}

TEST(ImportErrors, MissingEmptyAndCorruptFiles) {
    fs::path dir = tempDir("errors");
    expectError((dir / "nope.obj").string(), "not found");
    expectError(writeFile(dir, "empty.obj", ""), "empty");
    expectError(writeFile(dir, "bad.gltf", "{\"asset\": {\"version\": \"2.0\"}, \"meshes\": ["),
                "");
    expectError(writeFile(dir, "garbage.ply", "ply\nformat ascii 1.0\nelement vertex 3\n"
                                              "property float x\nend_header\nnot numbers\n"),
                "");
    auto missing = loadScene((dir / "nope.obj").string());
    EXPECT_FALSE(missing.isOk());
}

TEST(ImportErrors, AbsurdDeclaredCountsAreRefusedBeforeReading) {
    fs::path dir = tempDir("absurd");
    std::string header = "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\n"
                         "property float y\nproperty float z\nelement face 1\n"
                         "property list uchar int vertex_indices\nend_header\n0 0 0\n";
    expectError(writeFile(dir, "huge.ply", header), "4000000000");
    // Below the limit but far more than the bytes that follow.
    std::string binary = "ply\nformat binary_little_endian 1.0\nelement vertex 1000000\n"
                         "property float x\nproperty float y\nproperty float z\nend_header\n" +
                         std::string(24, '\0');
    expectError(writeFile(dir, "short.ply", binary), "only 24 bytes follow");
    expectError(writeFile(dir, "badcount.ply",
                          "ply\nformat ascii 1.0\nelement vertex -5\nproperty float x\n"
                          "end_header\n"),
                "bad count");
    // A glTF accessor declaring far more elements than its buffer holds.
    std::string gltf = readText(fixture("quad_camera.gltf"));
    size_t at = gltf.find("\"count\": 6,");
    ASSERT_NE(at, std::string::npos);
    gltf.replace(at, 11, "\"count\": 600000000,");
    expectError(writeFile(dir, "huge.gltf", gltf), "out of range");
    ImportOptions small;
    small.maxTriangles = 2;
    expectError(fixture("tiny.obj"), "more than 2", small);
    ImportOptions one;
    one.maxTriangles = 1;
    expectError(fixture("quad_camera.gltf"), "limit", one);
}

TEST(ImportErrors, NoTrianglesAndNonFiniteVertices) {
    fs::path dir = tempDir("geometry");
    expectError(writeFile(dir, "lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\n"),
                "no triangles");
    expectError(writeFile(dir, "points.ply",
                          "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                          "property float y\nproperty float z\nend_header\n0 0 0\n1 1 1\n"),
                "no triangles");
    expectError(writeFile(dir, "flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"),
                "degenerate");
    expectError(writeFile(dir, "nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"),
                "non-finite");
    expectError(writeFile(dir, "inf.ply",
                          "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                          "property float y\nproperty float z\nelement face 1\n"
                          "property list uchar int vertex_indices\nend_header\n"
                          "0 0 0\n1 0 0\n0 inf 0\n3 0 1 2\n"),
                "non-finite");
}

// Every truncated prefix of a valid file imports or fails cleanly (no crash, no hang).
void importEveryPrefix(const std::string& source, const std::string& ext, size_t step) {
    std::string bytes = readText(source);
    ASSERT_FALSE(bytes.empty());
    fs::path dir = tempDir("prefix" + ext);
    size_t ok = 0;
    for (size_t n = 0; n < bytes.size(); n += step) {
        std::string path = writeFile(dir, "prefix" + ext, bytes.substr(0, n));
        auto s = importFile(path);
        if (s.isOk()) {
            ++ok;
            EXPECT_GT(s->triangleCount(), 0u);
        } else {
            EXPECT_FALSE(s.status().message().empty());
        }
    }
    EXPECT_TRUE(importFile(writeFile(dir, "whole" + ext, bytes)).isOk());
    ::testing::Test::RecordProperty("prefixes_imported", int(ok));
}

TEST(ImportErrors, TruncatedPlyPrefixes) { importEveryPrefix(fixture("pyramid.ply"), ".ply", 1); }

TEST(ImportErrors, TruncatedGltfPrefixes) {
    importEveryPrefix(fixture("quad_camera.gltf"), ".gltf", 3);
}

}  // namespace
}  // namespace plx::scene
