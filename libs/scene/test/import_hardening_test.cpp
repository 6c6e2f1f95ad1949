// Hostile model files (issue 28): declared counts, instancing, polygon sizes and references are
// refused before they cost memory or time, or reach outside the model's folder; texture failures
// are warnings naming the texture. Every file is written by the test into a fresh folder.

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <unordered_map>

#include <unistd.h>

#include <gtest/gtest.h>

#include <plx/scene/import.h>

#include "expect_import_error.h"

#include "../src/normals.h"

namespace plx::scene {
namespace {

namespace fs = std::filesystem;

fs::path testDir(const std::string& name) { return freshTestDir("scene_hardening", name); }

std::string writeFile(const fs::path& path, const std::string& bytes) {
    return writeTestFile(path, bytes);
}

const char* kTriangleObj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n";

// A glTF with one triangle whose positions live in the given buffer URI.
std::string gltfWithBuffer(const std::string& uri, const std::string& nodes = R"([{"mesh":0}])") {
    return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":)" + nodes +
           R"(,"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
"buffers":[{"byteLength":36,"uri":")" +
           uri + R"("}],
"bufferViews":[{"buffer":0,"byteLength":36}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
"min":[0,0,0],"max":[1,1,0]}]})";
}

// 36 bytes of positions (0,0,0) (1,0,0) (0,1,0) as base64.
const char* kTriangleBase64 =
    "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA";

TEST(ImportLimits, OffCountsAreCheckedAgainstTheFileSize) {
    fs::path dir = testDir("off");
    const std::string body = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    expectError(writeFile(dir / "vertices.off", "OFF\n200000000 1 0\n" + body),
                "OFF header declares 200000000 vertices");
    expectError(writeFile(dir / "faces.off", "OFF\n3 200000000 0\n" + body), "200000000 faces");
    ImportOptions small;
    small.maxTriangles = 2;
    expectError(writeFile(dir / "limit.off", "OFF\n3 3 0\n" + body), "limit of 2", small);
    EXPECT_TRUE(importFile(writeFile(dir / "fine.off", "OFF\n3 1 0\n" + body)).isOk());
}

TEST(ImportLimits, OffFaceIndexOutOfRangeIsAnError) {
    fs::path dir = testDir("off_index");
    expectError(writeFile(dir / "index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 1000000\n"),
                "OFF face 0 (line 6) refers to vertex 1000000 of 3");
    expectError(writeFile(dir / "negative.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n"),
                "refers to vertex -1 of 3");
}

// A text .x file with one mesh of three vertices and the given faces ("3;0,1,2;").
std::string xFile(const std::string& faces, int count) {
    return "xof 0303txt 0032\ntemplate Mesh {\n <3D82AB44-62DA-11cf-AB39-0020AF71E433>\n"
           " DWORD nVertices;\n [...]\n}\nMesh tri {\n 3;\n 0.0;0.0;0.0;,\n 1.0;0.0;0.0;,\n"
           " 0.0;1.0;0.0;;\n " +
           std::to_string(count) + ";\n" + faces + ";\n}\n";
}

TEST(ImportLimits, XFaceIndexOutOfRangeIsAnError) {
    // assimp dropped the face without a word.
    fs::path dir = testDir("x_index");
    expectError(writeFile(dir / "index.x", xFile(" 3;0,1,2;,\n 3;0,1,2147483647;", 2)),
                ".x mesh 0 face 1 refers to vertex 2147483647 of 3");
    auto ok = importFile(writeFile(dir / "fine.x", xFile(" 3;0,1,2;,\n 3;0,2,1;", 2)));
    ASSERT_TRUE(ok.isOk()) << ok.status().message();
    EXPECT_EQ(ok->triangleCount(), 2u);
}

TEST(ImportLimits, XCountsBeyondTheFileAreErrors) {
    // One count changed to 2^31-1: assimp reserved that many and crashed.
    fs::path dir = testDir("x_count");
    expectError(writeFile(dir / "faces.x", xFile(" 3;0,1,2;,\n 3;0,2,1;", 2147483647)),
                ".x mesh 0 declares 2147483647 faces, more than the");
    std::string vertices = xFile(" 3;0,1,2;", 1);
    vertices.replace(vertices.find(" 3;\n 0.0"), 3, " 2147483647;");
    expectError(writeFile(dir / "vertices.x", vertices), "declares 2147483647 vertices");
}

// An import that cannot hang or crash the test if a check regresses: isolated, 10 s at most.
ImportOptions contained() {
    ImportOptions o;
    o.isolation.enabled = true;
    o.isolation.maxSeconds = 10.0;
    o.isolation.maxMemoryBytes = size_t(1) << 30;
    return o;
}

TEST(ImportLimits, SmdEndingInsideASectionIsTruncated) {
    // The reader looped forever at the end of a file inside its "nodes" block.
    fs::path dir = testDir("smd");
    const std::string nodes = "version 1\nnodes\n0 \"root\" -1\n";
    expectError(writeFile(dir / "nodes.smd", nodes), "SMD section 'nodes' (line 2) has no 'end'",
                contained());
    expectError(writeFile(dir / "empty_nodes.smd", "version 1\nnodes\n"), "has no 'end'",
                contained());
    const std::string good = nodes +
                             "end\nskeleton\ntime 0\n0 0 0 0 0 0 0\nend\ntriangles\nmat\n"
                             "0 0 0 0 0 0 1 0 0 1\n0 1 0 0 0 0 1 1 0 1\n0 0 1 0 0 0 1 0 1 1\nend\n";
    expectError(writeFile(dir / "triangles.smd", good.substr(0, good.size() - 4)),
                "SMD section 'triangles' (line 9) has no 'end'", contained());
    auto s = importFile(writeFile(dir / "good.smd", good), contained());
    ASSERT_TRUE(s.isOk()) << s.status().message();
    EXPECT_EQ(s->triangleCount(), 1u);
}

// An AC3D file of one quad, subdivided `subdiv` times (0: none).
std::string ac3dQuad(int subdiv) {
    return "AC3Db\nMATERIAL \"m\" rgb 1 1 1  amb 0.2 0.2 0.2  emis 0 0 0  spec 0.5 0.5 0.5  "
           "shi 10  trans 0\nOBJECT world\nkids 1\nOBJECT poly\nname \"quad\"\n" +
           (subdiv ? "subdiv " + std::to_string(subdiv) + "\n" : std::string()) +
           "numvert 4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\nnumsurf 1\nSURF 0x0\nmat 0\nrefs 4\n"
           "0 0 0\n1 1 0\n2 1 1\n3 0 1\nkids 0\n";
}

TEST(ImportLimits, Ac3dSubdivisionIsCountedBeforeAssimpSubdivides) {
    // "subdiv 9" (2^19 triangles from one quad) took 1.7 s; "subdiv 12" 24 s and 4 GB.
    fs::path dir = testDir("ac3d");
    expectError(writeFile(dir / "subdiv9.ac", ac3dQuad(9)),
                "AC3D subdivision (subdiv 9) makes more than the limit of 131072 triangles");
    expectError(writeFile(dir / "subdiv40.ac", ac3dQuad(40)), "(subdiv 40)");
    ImportOptions few;
    few.maxSubdividedTriangles = 2 * 4 * 4;  // one quad: 4 quads after one step, 16 after two
    auto two = importFile(writeFile(dir / "subdiv2.ac", ac3dQuad(2)), few);
    ASSERT_TRUE(two.isOk()) << two.status().message();
    EXPECT_EQ(two->triangleCount(), 32u);
    expectError(writeFile(dir / "subdiv3.ac", ac3dQuad(3)), "limit of 32 triangles", few);
    auto plain = importFile(writeFile(dir / "plain.ac", ac3dQuad(0)));
    ASSERT_TRUE(plain.isOk()) << plain.status().message();
    EXPECT_EQ(plain->triangleCount(), 2u);
}

TEST(ImportLimits, GlbChunkLengthBeyondTheFileIsAnError) {
    // A JSON chunk length of 0xFFFFFFF0 made the reader allocate 4 GB.
    const std::string json = R"({"asset":{"version":"2.0"}}  )";
    std::string glb = "glTF";
    auto u32 = [&](uint32_t v) { glb.append(reinterpret_cast<const char*>(&v), 4); };
    u32(2);
    u32(uint32_t(12 + 8 + json.size()));
    u32(0xFFFFFFF0u);
    glb += "JSON" + json;
    fs::path dir = testDir("glb_chunk");
    expectError(writeFile(dir / "chunk.glb", glb), "GLB has no complete JSON chunk");
}

TEST(ImportLimits, DoubledGltfChildrenFailFastNamingTheLimit) {
    // 40 levels, each node listing its child twice: 2^40 copies of the leaf in 1.7 KB.
    std::string nodes = "[";
    for (int i = 0; i < 40; ++i)
        nodes += "{\"children\":[" + std::to_string(i + 1) + "," + std::to_string(i + 1) + "]},";
    nodes += "{\"mesh\":0}]";
    fs::path dir = testDir("doubled");
    expectError(writeFile(dir / "doubled.gltf", gltfWithBuffer(kTriangleBase64, nodes)),
                "limit of 1048576 node copies");
    ImportOptions few;
    few.maxNodeCopies = 4;
    std::string twice = R"([{"children":[1,1]},{"mesh":0}])";
    EXPECT_TRUE(
        importFile(writeFile(dir / "twice.gltf", gltfWithBuffer(kTriangleBase64, twice))).isOk());
    expectError(
        writeFile(dir / "twice_limit.gltf",
                  gltfWithBuffer(kTriangleBase64, R"([{"children":[1,1,1,1]},{"mesh":0}])")),
        "limit of 4 node copies", few);
    expectError(
        writeFile(dir / "cycle.gltf",
                  gltfWithBuffer(kTriangleBase64, R"([{"children":[1]},{"children":[0]}])")),
        "cycle");
}

TEST(ImportLimits, PolygonWithTooManyCornersIsRefused) {
    // One polygon of 100,000 corners: assimp's ear clipping would take about a minute.
    std::string obj;
    const int n = 100000;
    char line[64];
    for (int i = 0; i < n; ++i) {
        std::snprintf(line, sizeof(line), "v %.6f %.6f 0\n", std::cos(2 * M_PI * i / n),
                      std::sin(2 * M_PI * i / n));
        obj += line;
    }
    obj += "f";
    for (int i = 1; i <= n; ++i) {
        std::snprintf(line, sizeof(line), " %d", i);
        obj += line;
    }
    obj += "\n";
    fs::path dir = testDir("polygon");
    expectError(writeFile(dir / "polygon.obj", obj),
                "face 0 has 100000 corners, more than the limit of 4096");
}

// The method before issue 28, kept as the reference: for each corner, every face around its
// position (quadratic in a fan).
std::vector<Vec3> referenceCornerNormals(const std::vector<Vec3>& pos,
                                         const std::vector<Corners>& tris) {
    const float cosLimit = std::cos(radians(80.0f));
    std::vector<Vec3> faceN(tris.size()), unitN(tris.size());
    for (size_t t = 0; t < tris.size(); ++t) {
        const Corners& c = tris[t];
        faceN[t] = glm::cross(pos[c[1]] - pos[c[0]], pos[c[2]] - pos[c[0]]);
        float len = glm::length(faceN[t]);
        unitN[t] = len > 0.0f ? faceN[t] / len : Vec3(0.0f);
    }
    std::map<std::array<float, 3>, std::vector<uint32_t>> facesAt;
    auto key = [&](unsigned v) { return std::array<float, 3>{pos[v].x, pos[v].y, pos[v].z}; };
    for (size_t t = 0; t < tris.size(); ++t)
        for (unsigned v : tris[t]) facesAt[key(v)].push_back(uint32_t(t));
    std::vector<Vec3> out(3 * tris.size());
    for (size_t t = 0; t < tris.size(); ++t)
        for (int k = 0; k < 3; ++k) {
            const std::vector<uint32_t>& around = facesAt[key(tris[t][k])];
            Vec3 n(0.0f);
            for (uint32_t u : around)
                if (around.size() > kMaxPairwiseFaces || glm::dot(unitN[u], unitN[t]) >= cosLimit)
                    n += faceN[u];
            out[3 * t + k] = n;
        }
    return out;
}

// A fan of n triangles around the origin (one shared vertex), bent so that neighbours differ.
void addFan(int n, float bend, std::vector<Vec3>* pos, std::vector<Corners>* tris) {
    unsigned centre = unsigned(pos->size());
    pos->push_back(Vec3(0.0f));
    for (int i = 0; i <= n; ++i) {
        float a = 2.0f * float(M_PI) * float(i) / float(n);
        pos->push_back(Vec3(std::cos(a), std::sin(a), (i % 2) * bend));
    }
    for (int i = 0; i < n; ++i) tris->push_back({centre, centre + 1 + i, centre + 2 + i});
}

TEST(ImportNormals, LinearMethodEqualsTheReference) {
    std::vector<Vec3> pos;
    std::vector<Corners> tris;
    addFan(300, 0.0f, &pos, &tris);  // busier than kMaxPairwiseFaces: one averaged normal
    addFan(24, 0.8f, &pos, &tris);   // pairwise, with folds beyond 80 degrees
    // A box corner: three faces at right angles (sharp edges stay sharp).
    unsigned b = unsigned(pos.size());
    pos.insert(pos.end(), {Vec3(5, 0, 0), Vec3(6, 0, 0), Vec3(5, 1, 0), Vec3(5, 0, 1)});
    tris.insert(tris.end(),
                {Corners{b, b + 2, b + 1}, Corners{b, b + 1, b + 3}, Corners{b, b + 3, b + 2}});
    std::vector<Vec3> fast = smoothCornerNormals(pos, tris),
                      ref = referenceCornerNormals(pos, tris);
    ASSERT_EQ(fast.size(), ref.size());
    for (size_t c = 0; c < fast.size(); ++c) EXPECT_EQ(fast[c], ref[c]) << "corner " << c;
}

TEST(ImportNormals, CornersShareAVertexOnlyWhenEveryAttributeIsEqual) {
    // Two coplanar triangles sharing an edge (one vertex each way), and a third over the same
    // corners facing the other way, one of its corners with another UV.
    fs::path dir = testDir("join");
    auto s = importFile(writeFile(dir / "join.obj",
                                  "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n"
                                  "vt 0 1\nvt 0.5 0.5\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\nf 1/5 4/4 3/3\n"));
    ASSERT_TRUE(s.isOk()) << s.status().message();
    ASSERT_EQ(s->meshes.size(), 1u);
    const Mesh& m = s->meshes[0];
    // 4 vertices facing +z; 3 facing -z (normals differ), one of which also differs in UV.
    EXPECT_EQ(m.vertexCount(), 7u);
    EXPECT_EQ(m.indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 4, 5, 6}));
    EXPECT_EQ(m.uvs[4], Vec2(0.5f, 0.5f));
}

TEST(ImportNormals, HugeFanAroundOneVertexImports) {
    // 400,000 triangles around one shared vertex: quadratic normal generation took over 30 s.
    const int n = 400000;
    std::string obj = "v 0 0 0\n";
    obj.reserve(size_t(n) * 40);
    char line[64];
    for (int i = 0; i <= n; ++i) {
        float a = 2.0f * float(M_PI) * float(i) / float(n);
        std::snprintf(line, sizeof(line), "v %.7f %.7f 0\n", std::cos(a), std::sin(a));
        obj += line;
    }
    for (int i = 0; i < n; ++i) {
        std::snprintf(line, sizeof(line), "f 1 %d %d\n", i + 2, i + 3);
        obj += line;
    }
    fs::path dir = testDir("fan");
    auto s = importFile(writeFile(dir / "fan.obj", obj));
    ASSERT_TRUE(s.isOk()) << s.status().message();
    EXPECT_GT(s->triangleCount(), size_t(n) * 99 / 100);  // a few sliver triangles may be zero area
    // The reader's one vertex per corner is joined back to one per file vertex.
    size_t vertices = 0;
    for (const Mesh& m : s->meshes) vertices += m.vertexCount();
    EXPECT_EQ(vertices, size_t(n) + 2);
    // Every triangle is in the plane z = 0: the averaged normals are +z.
    for (const Mesh& m : s->meshes)
        for (const Vec3& nrm : m.normals) ASSERT_NEAR(std::abs(nrm.z), 1.0f, 1e-4f);
}

// The positions (0,0,0) (1,0,0) (0,1,0) as a little-endian float buffer.
std::string triangleBuffer() {
    const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    std::string bytes(sizeof(xyz), '\0');
    std::memcpy(bytes.data(), xyz, sizeof(xyz));
    return bytes;
}

TEST(ImportRefs, GltfBufferOutsideTheFolderIsRefused) {
    fs::path dir = testDir("gltf_buffer");
    writeFile(dir / "outside.bin", triangleBuffer());
    std::string path = writeFile(dir / "model" / "up.gltf", gltfWithBuffer("../outside.bin"));
    expectError(path, "points outside the model's folder");
    expectError(
        writeFile(dir / "model" / "passwd.gltf", gltfWithBuffer("../../../../../../../etc/passwd")),
        "points outside the model's folder");
    // assimp joins absolute and file:// URIs to the model's folder, where they name nothing.
    expectError(
        writeFile(dir / "model" / "absolute.gltf", gltfWithBuffer((dir / "outside.bin").string())),
        "could not open");
    expectError(writeFile(dir / "model" / "fileuri.gltf",
                          gltfWithBuffer("file://" + (dir / "outside.bin").string())),
                "could not open");
    // A symlink inside the folder that points out is outside too.
    fs::create_symlink(dir / "outside.bin", dir / "model" / "link.bin");
    expectError(writeFile(dir / "model" / "link.gltf", gltfWithBuffer("link.bin")),
                "points outside the model's folder");
    ImportOptions allow;
    allow.allowExternalRefs = true;
    EXPECT_TRUE(importFile(path, allow).isOk());
    // Inside the folder, a subfolder is fine.
    writeFile(dir / "model" / "sub" / "in.bin", triangleBuffer());
    EXPECT_TRUE(
        importFile(writeFile(dir / "model" / "in.gltf", gltfWithBuffer("sub/in.bin"))).isOk());
}

TEST(ImportRefs, ObjMaterialLibraryOutsideIsRefusedWithoutQuotingIt) {
    fs::path dir = testDir("obj_mtllib");
    writeFile(dir / "secret.txt", "SECRET-CONTENT line one\nSECRET-CONTENT line two\n");
    std::string path = writeFile(dir / "model" / "m.obj", std::string("mtllib ../secret.txt\n") +
                                                              kTriangleObj + "usemtl x\nf 1 2 3\n");
    expectError(path, "points outside the model's folder");
    EXPECT_EQ(importFile(path).status().message().find("SECRET"), std::string::npos);
    expectError(writeFile(dir / "model" / "passwd.obj",
                          std::string("mtllib ../../../../../../etc/passwd\n") + kTriangleObj +
                              "f 1 2 3\n"),
                "points outside the model's folder");
}

TEST(ImportRefs, TexturesOutsideTheFolderAreRefused) {
    fs::path dir = testDir("obj_texture");
    fs::copy_file(std::string(PLX_SOURCE_DIR) + "/libs/scene/test/fixtures/tiny.png",
                  dir / "outside.png");
    auto objWithTexture = [&](const std::string& name, const std::string& texture) {
        writeFile(dir / "model" / (name + ".mtl"), "newmtl a\nmap_Kd " + texture + "\n");
        return writeFile(dir / "model" / (name + ".obj"),
                         "mtllib " + name + ".mtl\n" + kTriangleObj + "usemtl a\nf 1/1 2/2 3/3\n");
    };
    std::string up = objWithTexture("up", "../outside.png");
    expectError(up, "reference '../outside.png' points outside the model's folder");
    expectError(objWithTexture("abs", (dir / "outside.png").string()), "points outside");
    ImportOptions allow;
    allow.allowExternalRefs = true;
    auto s = importFile(up, allow);
    ASSERT_TRUE(s.isOk()) << s.status().message();
    EXPECT_EQ(s->textures.size(), 1u);
}

TEST(ImportTextures, DecodeFailuresAreWarningsNamingTheTexture) {
    fs::path dir = testDir("bad_textures");
    writeFile(dir / "corrupt.png", std::string("\x89PNG\r\n\x1a\n", 8) + std::string(64, 'x'));
    writeFile(dir / "corrupt.jpg", std::string("\xff\xd8\xff\xe0", 4) + std::string(64, 'x'));
    fs::copy_file(std::string(PLX_SOURCE_DIR) + "/libs/scene/test/fixtures/tiny.png",
                  dir / "tiny.png");
    std::string mtl, obj = "mtllib m.mtl\n" + std::string(kTriangleObj);
    int k = 0;
    for (const char* tex : {"corrupt.png", "corrupt.jpg", "missing.png", "tiny.png"}) {
        mtl += "newmtl m" + std::to_string(k) + "\nmap_Kd " + tex + "\n";
        obj += "usemtl m" + std::to_string(k++) + "\nf 1/1 2/2 3/3\n";
    }
    writeFile(dir / "m.mtl", mtl);
    std::string path = writeFile(dir / "m.obj", obj);
    auto s = importFile(path);
    ASSERT_TRUE(s.isOk()) << s.status().message();
    EXPECT_EQ(s->texturesMissing, 3u);
    EXPECT_EQ(s->textures.size(), 1u);
    ASSERT_EQ(s->warnings.size(), 3u);
    EXPECT_NE(s->warnings[0].find("texture 'corrupt.png'"), std::string::npos) << s->warnings[0];
    EXPECT_NE(s->warnings[1].find("texture 'corrupt.jpg'"), std::string::npos) << s->warnings[1];
    EXPECT_NE(s->warnings[2].find("texture 'missing.png'"), std::string::npos) << s->warnings[2];
    // A texture over the pixel limit is a warning too, decided before decoding.
    ImportOptions tiny;
    tiny.maxTexturePixels = 1;
    auto limited = importFile(path, tiny);
    ASSERT_TRUE(limited.isOk());
    EXPECT_EQ(limited->texturesMissing, 4u);
    EXPECT_NE(limited->warnings[3].find("limit of 1 pixels"), std::string::npos)
        << limited->warnings[3];
}

TEST(ImportTextures, HugeDeclaredAndUndecodableEmbeddedTexturesAreWarnings) {
    // A PNG declaring 100000x100000 pixels (57 bytes) is refused from its header, before
    // decoding. An embedded image of unknown format (the base64 decodes to garbage) is a warning
    // naming it too; it once failed the whole import without naming the texture.
    fs::path dir = testDir("huge_texture");
    fs::copy_file(std::string(PLX_SOURCE_DIR) + "/libs/scene/test/fixtures/declares_100000x100000.png",
                  dir / "huge.png");
    writeFile(dir / "m.mtl", "newmtl a\nmap_Kd huge.png\n");
    auto s = importFile(writeFile(
        dir / "m.obj", "mtllib m.mtl\n" + std::string(kTriangleObj) + "usemtl a\nf 1/1 2/2 3/3\n"));
    ASSERT_TRUE(s.isOk()) << s.status().message();
    EXPECT_EQ(s->texturesMissing, 1u);
    ASSERT_EQ(s->warnings.size(), 1u);
    EXPECT_NE(s->warnings[0].find("texture 'huge.png'"), std::string::npos) << s->warnings[0];
    EXPECT_NE(s->warnings[0].find("declares 100000x100000 pixels"), std::string::npos)
        << s->warnings[0];

    std::string gltf = gltfWithBuffer(kTriangleBase64);
    gltf.insert(gltf.rfind('}'),
                R"(,"materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],
"textures":[{"source":0}],"images":[{"uri":"data:image/png;base64,****AAAA"}])");
    gltf.replace(gltf.find(R"("attributes":{"POSITION":0}})"), 28,
                 R"("attributes":{"POSITION":0},"material":0})");
    auto b = importFile(writeFile(dir / "b64.gltf", gltf));
    ASSERT_TRUE(b.isOk()) << b.status().message();
    EXPECT_EQ(b->texturesMissing, 1u);
    ASSERT_EQ(b->warnings.size(), 1u);
    EXPECT_NE(b->warnings[0].find("texture '*0' not loaded: not a PNG or JPEG"), std::string::npos)
        << b->warnings[0];
    // Characters outside base64 make assimp refuse the file, without quoting them.
    gltf.replace(gltf.find("****AAAA"), 8, "!!not*base64!!");
    expectError(writeFile(dir / "invalid.gltf", gltf), "Invalid base64 encoded data");
}

TEST(ImportTextures, DevicesAndFifosAreNotRead) {
    fs::path dir = testDir("texture_fifo");
    ASSERT_EQ(mkfifo((dir / "fifo.png").c_str(), 0600), 0);
    writeFile(dir / "m.mtl", "newmtl a\nmap_Kd fifo.png\n");
    auto s = importFile(writeFile(
        dir / "m.obj", "mtllib m.mtl\n" + std::string(kTriangleObj) + "usemtl a\nf 1/1 2/2 3/3\n"));
    ASSERT_TRUE(s.isOk()) << s.status().message();
    ASSERT_EQ(s->warnings.size(), 1u);
    EXPECT_NE(s->warnings[0].find("FIFO"), std::string::npos) << s->warnings[0];
    // /dev/zero through a link, with external references allowed: refused as a device.
    fs::create_symlink("/dev/zero", dir / "zero.png");
    writeFile(dir / "z.mtl", "newmtl a\nmap_Kd zero.png\n");
    ImportOptions allow;
    allow.allowExternalRefs = true;
    auto z = importFile(writeFile(dir / "z.obj", "mtllib z.mtl\n" + std::string(kTriangleObj) +
                                                     "usemtl a\nf 1/1 2/2 3/3\n"),
                        allow);
    ASSERT_TRUE(z.isOk()) << z.status().message();
    ASSERT_EQ(z->warnings.size(), 1u);
    EXPECT_NE(z->warnings[0].find("character device"), std::string::npos) << z->warnings[0];
}

TEST(ImportErrors, AssimpMessagesDoNotQuoteFileContent) {
    fs::path dir = testDir("quoted");
    std::string gltf = gltfWithBuffer("data:application/octet-stream;base64,SECRET!!!***");
    std::string path = writeFile(dir / "b64.gltf", gltf);
    auto s = importFile(path);
    ASSERT_FALSE(s.isOk());
    EXPECT_EQ(s.status().message().find("SECRET"), std::string::npos) << s.status().message();
}

}  // namespace
}  // namespace plx::scene
