// Issue 28 as a user meets it: hostile or mistaken input files and options give one line naming
// the problem and a non-zero exit, never a hang, a bare std::bad_alloc or a silent blank image.
// Each case was observed before the fix; the files are written here, in a scratch folder.

#include <cstring>
#include <utility>

#include <sys/stat.h>

#include <nlohmann/json.hpp>

#include <plx/core/image_io.h>
#include <plx/core/status.h>

#include "cli_runner.h"

namespace {

using namespace plx::testing;

fs::path hardDir() {
    return plx::testing::scratchDir("hardening_cli");
}

fs::path makeFifo(const std::string& name) {
    fs::path p = hardDir() / name;
    fs::remove(p);
    EXPECT_EQ(mkfifo(p.c_str(), 0600), 0);
    return p;
}

TEST(HardeningCli, DirectoriesAndFifosAreRefusedAtOnce) {
    fs::path folder = hardDir() / "a_folder";
    fs::create_directories(folder);
    fs::path fifo = makeFifo("input.fifo");
    const std::string out = " -o " + (hardDir() / "x.png").string();
    for (const std::string cmd : {"ptm info ", "ptm verify ", "ptm decode "}) {
        expectOneLineError(runParallax(cmd + q(folder) + (cmd == "ptm decode " ? out : "")),
                           "is a directory, not a regular file");
        expectOneLineError(runParallax(cmd + q(fifo) + (cmd == "ptm decode " ? out : "")),
                           "is a FIFO (named pipe), not a regular file");
    }
    const std::string pre = " --error 1 --out " + (hardDir() / "p").string();
    expectOneLineError(runParallax("predistort " + q(folder) + pre), "is a directory");
    expectOneLineError(runParallax("predistort " + q(fifo) + pre), "FIFO");
    const std::string st = "stereo office:1 --size 32x24 --out " + (hardDir() / "s").string();
    expectOneLineError(runParallax(st + " --path " + q(folder)), "is a directory");
    expectOneLineError(runParallax(st + " --path " + q(fifo)), "FIFO");
    expectOneLineError(runParallax("info " + q(fifo)), "FIFO");
    expectOneLineError(
        runParallax("ptm verify " + q(hardDir() / "none.ptm") + " --against " + q(folder)),
        "file not found");
}

TEST(HardeningCli, SymlinkLoopIsNamed) {
    fs::path a = hardDir() / "loop_a", b = hardDir() / "loop_b";
    fs::remove(a);
    fs::remove(b);
    fs::create_symlink(b, a);
    fs::create_symlink(a, b);
    expectOneLineError(runParallax("ptm info " + q(a)), "symlink loop");
    expectOneLineError(runParallax("info " + q(a)), "symlink loop");
}

// A PNG whose header declares width x height grey pixels; its image data is one empty chunk.
std::string pngDeclaring(uint32_t width, uint32_t height) {
    auto be32 = [](std::string* s, uint32_t x) {
        for (int k = 24; k >= 0; k -= 8) s->push_back(char(x >> k));
    };
    auto chunk = [&](std::string* png, const std::string& typeAndData) {
        uint32_t crc = 0xFFFFFFFFu;
        for (unsigned char c : typeAndData) {
            crc ^= c;
            for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
        }
        be32(png, uint32_t(typeAndData.size() - 4));
        *png += typeAndData;
        be32(png, ~crc);
    };
    std::string ihdr = "IHDR";
    be32(&ihdr, width);
    be32(&ihdr, height);
    ihdr += std::string("\x08\0\0\0\0", 5);
    std::string png("\x89PNG\r\n\x1a\n", 8);
    chunk(&png, ihdr);
    chunk(&png, "IDAT");
    chunk(&png, "IEND");
    return png;
}

TEST(HardeningCli, PtmEncodeRefusesImagesOverThePixelLimit) {
    fs::path big = hardDir() / "zeros16k.png";
    writeFile(big, pngDeclaring(16384, 16384));
    const std::string out = " -o " + (hardDir() / "big.ptm").string();
    expectOneLineError(runParallax("ptm encode " + q(big) + out),
                       "declares 16384x16384 pixels, more than the limit of 67108864 pixels");
    plx::ByteImage small{8, 8, 1, std::vector<uint8_t>(64, 7)};
    fs::path png = hardDir() / "small.png";
    ASSERT_TRUE(plx::writePng(png.string(), small).isOk());
    expectOneLineError(runParallax("ptm encode " + q(png) + out + " --max-pixels 63"),
                       "limit of 63 pixels");
    EXPECT_EQ(runParallax("ptm encode " + q(png) + out + " --max-pixels 64").exitCode, 0);
}

TEST(HardeningCli, DeclaredCountsAndInstancingFailFast) {
    fs::path off = hardDir() / "huge.off";
    writeFile(off, "OFF\n200000000 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    expectOneLineError(runParallax("info " + q(off)), "OFF header declares 200000000 vertices");
    fs::path faces = hardDir() / "faces.off";
    writeFile(faces, "OFF\n3 200000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    expectOneLineError(runParallax("info " + q(faces)), "200000000 faces");
    fs::path index = hardDir() / "index.off";
    writeFile(index, "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 1000000\n");
    expectOneLineError(runParallax("render " + q(index) + " --out " + (hardDir() / "r").string()),
                       "OFF face 0 (line 6) refers to vertex 1000000 of 3");
    std::string nodes;
    for (int i = 0; i < 40; ++i)
        nodes += "{\"children\":[" + std::to_string(i + 1) + "," + std::to_string(i + 1) + "]},";
    fs::path doubled = hardDir() / "doubled.gltf";
    writeFile(doubled, R"({"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[)" + nodes +
                           R"({"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
"accessors":[{"componentType":5126,"count":3,"type":"VEC3"}]})");
    expectOneLineError(runParallax("info " + q(doubled)), "limit of 1048576 node copies");
}

TEST(HardeningCli, ReferencesStayInTheModelsFolder) {
    fs::path model = hardDir() / "refs" / "model";
    fs::create_directories(model);
    fs::path gltf = model / "passwd.gltf";
    writeFile(gltf, R"({"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
"buffers":[{"byteLength":36,"uri":"../../../../../../../../etc/passwd"}],
"bufferViews":[{"buffer":0,"byteLength":36}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}]})");
    expectOneLineError(runParallax("info " + q(gltf)), "points outside the model's folder");
    fs::path obj = model / "mtllib.obj";
    writeFile(obj,
              "mtllib ../../../../../../../../etc/passwd\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"
              "usemtl x\nf 1 2 3\n");
    RunResult r = runParallax("info " + q(obj));
    expectOneLineError(r, "points outside the model's folder");
    EXPECT_EQ(r.err.find("root:"), std::string::npos) << r.err;
    // The option lets a trusted model reach out: the texture then loads.
    fs::path png = hardDir() / "refs" / "outside.png";
    ASSERT_TRUE(
        plx::writePng(png.string(), plx::ByteImage{2, 2, 3, std::vector<uint8_t>(12, 9)}).isOk());
    writeFile(model / "up.mtl", "newmtl a\nmap_Kd ../outside.png\n");
    fs::path up = model / "up.obj";
    writeFile(up,
              "mtllib up.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl a\n"
              "f 1/1 2/2 3/3\n");
    expectOneLineError(runParallax("info " + q(up)), "reference '../outside.png' points outside");
    RunResult allowed = runParallax("info " + q(up) + " --json --allow-external-refs");
    ASSERT_EQ(allowed.exitCode, 0) << allowed.err;
    EXPECT_EQ(nlohmann::json::parse(allowed.out)["textures"], 1);
}

TEST(HardeningCli, TextureFailuresWarnAndStrictFails) {
    fs::path model = hardDir() / "badtex";
    fs::create_directories(model);
    writeFile(model / "corrupt.png", std::string("\x89PNG\r\n\x1a\n", 8) + "not a png at all");
    writeFile(model / "m.mtl", "newmtl a\nmap_Kd corrupt.png\n");
    fs::path obj = model / "m.obj";
    writeFile(obj,
              "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl a\n"
              "f 1/1 2/2 3/3\n");
    RunResult r = runParallax("info " + q(obj) + " --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["textures_failed"], 1);
    EXPECT_EQ(r.err.rfind("parallax: warning: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find("texture 'corrupt.png' not loaded"), std::string::npos) << r.err;
    expectOneLineError(runParallax("render " + q(obj) +
                                   " --shading textured --strict --size "
                                   "32x24 --out " +
                                   (hardDir() / "t").string()),
                       "texture 'corrupt.png' not loaded");
}

TEST(HardeningCli, OptionsThatCanOnlyGiveNothingAreErrors) {
    const std::string render = "render office:1 --size 32x24 --out " + (hardDir() / "r").string();
    expectOneLineError(runParallax(render + " --fov 0"), "--fov 0 must lie strictly between", 2);
    expectOneLineError(runParallax(render + " --fov 180"), "--fov 180", 2);
    expectOneLineError(runParallax(render + " --fov -5"), "--fov -5", 2);
    // Named as typed, not as the float it rounds to (inf).
    expectOneLineError(runParallax(render + " --fov 1e308"), "--fov 1e308 must lie strictly", 2);
    // Once read as "not given" and replaced by the viewpoint's own.
    expectOneLineError(runParallax(render + " --fov nan"), "--fov nan must lie strictly between",
                       2);
    expectOneLineError(runParallax(render + " --target 1,1,1"), "--target needs --eye", 2);
    expectOneLineError(runParallax(render + " --eye 1e38,1,1 --target 0,0,0"),
                       "camera eye (1e+38, 1, 1) is too far from the origin", 2);
    const std::string stereo = "stereo office:1 --size 32x24 --out " + (hardDir() / "s").string();
    expectOneLineError(runParallax(stereo + " --walk 0"), "--walk 0 outside 1 .. 100000", 2);
    // Once read as "not given" (the old sentinel) and the single pose rendered.
    expectOneLineError(runParallax(stereo + " --walk -1"), "--walk -1 outside 1 .. 100000", 2);
    // The experiments' numbers are usage too (exit status 2), named in the message.
    const std::pair<std::string, std::string> benchErrors[] = {
        {"stereo --separation nan", "--separation: 'nan' is not a finite number"},
        {"stereo --convergence 1e300", "--convergence: '1e300' is beyond a float's range"},
        {"warp --composite-tolerance 1e300",
         "--composite-tolerance: '1e300' is beyond a float's range"},
        {"stereo --convergence 0", "convergence distance 0 must be a finite number > 0"},
        {"predistort --thresholds 4,nan",
         "--thresholds: error threshold nan mm must be a finite number > 0"},
    };
    for (const auto& [args, message] : benchErrors)
        expectOneLineError(runParallax("bench " + args + " --out " + (hardDir() / "b").string()),
                           message, 2);
    // Once read as infinity by the option and reported as "eye separation inf".
    expectOneLineError(runParallax(stereo + " --separation 1e300"),
                       "--separation: '1e300' is beyond a float's range", 2);
    // Once "PSNR 99 dB" and blank images: the eyes, 5e29 to each side, are refused up front.
    expectOneLineError(runParallax(stereo + " --separation 1e30"),
                       "eye separation 1e+30 puts the left eye out of range: camera eye "
                       "(-5e+29, 0, 5) is too far from the origin",
                       2);
    // Within float range but looking past the scene: refused after the first eye.
    expectOneLineError(runParallax(stereo + " --separation 1e6 --rig parallel"),
                       "the first eye sees none of the scene");
    // A convergence point so near that the eyes' image shift leaves the scene out of view.
    expectOneLineError(runParallax(stereo + " --convergence 1e-30"),
                       "the first eye sees none of the scene (check --separation, --convergence");
    expectOneLineError(runParallax("predistort cone_showcase --viewer=0,-5000,0 --error 1 --out " +
                                   (hardDir() / "p").string()),
                       "sees none of the display's content");
    // Once 16384-pixel faces (8 GiB) and a frame of holes for a 160x120 output.
    expectOneLineError(runParallax("warp office:1 --size 160x120 --to-eye 1,1,1 --fov 0.0001 "
                                   "--out " +
                                   (hardDir() / "w").string()),
                       "field of view over 120 rows needs reference faces over 16384 pixels", 2);
}

// An empty --out wrote a database into the working folder before failing, and a prefix ending in
// '/' wrote hidden files (out/.color.png); both are usage errors now, before any work.
TEST(HardeningCli, OutputPathsMustNameSomething) {
    const fs::path dir = hardDir() / "outputs";
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string prefixCommands[] = {"render office:1 --size 32x24",
                                          "stereo office:1 --size 32x24",
                                          "predistort cone_showcase --error 2"};
    for (const std::string& command : prefixCommands) {
        expectOneLineError(runParallax(command + " --out ''"), "--out", 2);
        expectOneLineError(runParallax(command + " --out " + q(dir) + "/"),
                           "ends in a folder; the prefix needs a file name", 2);
    }
    expectOneLineError(runParallax("stream build museum:1 --out ''"), "--out", 2);
    EXPECT_TRUE(fs::is_empty(dir));
    expectOneLineError(runParallax("--import-seconds nan info office:1"),
                       "--import-seconds: 'nan' is not a finite number", 2);
}

TEST(HardeningCli, AHugeValueIsQuotedByItsEnds) {
    // 100,000 characters (a single argument may hold 128 KiB): the line quotes their two ends.
    const std::string size = std::string(100000, '7') + "x9";
    const RunResult r = runParallax("render office:1 --out x --size " + size);
    expectOneLineError(r, "bytes left out", 2);
    EXPECT_LE(r.err.size(), plx::kMaxMessageChars + 64);
    EXPECT_NE(r.err.find("(e.g. 1280x720)"), std::string::npos) << r.err;
}

TEST(HardeningCli, InvalidJsonGivesLineAndColumn) {
    fs::path bad = hardDir() / "bad.json";
    writeFile(bad, "{\n  \"a\": [1,\n    2,, 3]\n}\n");
    expectOneLineError(runParallax("predistort " + q(bad) + " --error 1 --out x"),
                       "not valid JSON at line 3, column 7");
    expectOneLineError(runParallax("stereo office:1 --path " + q(bad) + " --out x"),
                       "not valid JSON at line 3, column 7");
}

}  // namespace
