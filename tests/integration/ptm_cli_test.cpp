// parallax ptm encode, info, decode and verify run as a user would, bad input included.

#include <nlohmann/json.hpp>

#include <plx/core/image_io.h>

#include "cli_runner.h"

namespace {

using namespace plx::testing;

fs::path ptmDir() {
    return plx::testing::scratchDir("ptm_cli");
}

// An RGB texture with odd sides (37x23: seven levels down to 1x1) and some structure.
fs::path writeTexture(const std::string& name, uint32_t seed) {
    plx::ByteImage img{37, 23, 3, std::vector<uint8_t>(37 * 23 * 3)};
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            for (int k = 0; k < 3; ++k)
                img.pixel(x, y)[k] = uint8_t((x * 5 + y * 3 + k * 50 + (x * y + seed) % 11) & 255);
    const fs::path path = ptmDir() / name;
    EXPECT_TRUE(plx::writePng(path.string(), img).isOk());
    return path;
}

std::string readAll(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), {});
}

TEST(PtmCli, EncodeInfoDecodeVerify) {
    const fs::path png = writeTexture("tex.png", 1), ptm = ptmDir() / "tex.ptm";
    RunResult enc = runParallax("ptm encode " + png.string() + " -o " + ptm.string() + " --json");
    ASSERT_EQ(enc.exitCode, 0) << enc.err;
    const auto e = nlohmann::json::parse(enc.out);
    EXPECT_EQ(e["bytes"].get<uint64_t>(), fs::file_size(ptm));

    RunResult info = runParallax("ptm info " + ptm.string() + " --json");
    ASSERT_EQ(info.exitCode, 0) << info.err;
    const auto doc = nlohmann::json::parse(info.out);
    EXPECT_EQ(doc["coder"], "rans");
    EXPECT_EQ(doc["levels"].get<int>(), 7);
    EXPECT_TRUE(doc["file_complete"].get<bool>());
    // Level groups smallest first, contiguous, ending at the end of the file.
    uint64_t next = doc["level_groups"][0]["offset"].get<uint64_t>();
    for (const auto& g : doc["level_groups"]) {
        EXPECT_EQ(g["offset"].get<uint64_t>(), next);
        next += g["bytes"].get<uint64_t>();
    }
    EXPECT_EQ(next, fs::file_size(ptm));
    EXPECT_EQ(doc["level_groups"][6]["width"].get<int>(), 37);
    // Coder rans says how each group was coded: the 1x1 level is always stored (3 bytes against
    // a modelled group's tables), a modelled level k >= 1 names its shape weight.
    EXPECT_TRUE(doc["level_groups"][0]["stored"].get<bool>());
    for (const auto& g : doc["level_groups"]) {
        ASSERT_TRUE(g.contains("stored"));
        if (g["stored"].get<bool>() || g["level"].get<int>() == 0) continue;
        const int w = g["shape_eighths"].get<int>();
        EXPECT_TRUE(w >= 0 && w <= 4) << w;
    }
    RunResult text = runParallax("ptm info " + ptm.string());
    EXPECT_NE(text.out.find(":1, stored)"), std::string::npos) << text.out;

    const fs::path top = ptmDir() / "top.png", low = ptmDir() / "low.png";
    ASSERT_EQ(runParallax("ptm decode " + ptm.string() + " -o " + top.string()).exitCode, 0);
    EXPECT_EQ(*plx::readImage(top.string()), *plx::readImage(png.string()));
    ASSERT_EQ(runParallax("ptm decode " + ptm.string() + " --level 1 -o " + low.string()).exitCode,
              0);
    auto lowImage = plx::readImage(low.string());
    ASSERT_TRUE(lowImage.isOk());
    EXPECT_EQ(lowImage->width, 2);
    EXPECT_EQ(lowImage->height, 1);

    RunResult verify =
        runParallax("ptm verify " + ptm.string() + " --against " + png.string() + " --json");
    ASSERT_EQ(verify.exitCode, 0) << verify.err;
    EXPECT_EQ(nlohmann::json::parse(verify.out)["against"], "bit-exact, every level");
}

TEST(PtmCli, EveryCoderAndShapeWeightRoundTrips) {
    const fs::path png = writeTexture("coders.png", 2), ptm = ptmDir() / "coders.ptm";
    auto roundTrips = [&](const std::string& option) {
        RunResult enc =
            runParallax("ptm encode " + png.string() + " -o " + ptm.string() + " " + option);
        ASSERT_EQ(enc.exitCode, 0) << option << ": " << enc.err;
        RunResult v = runParallax("ptm verify " + ptm.string() + " --against " + png.string());
        EXPECT_EQ(v.exitCode, 0) << option << ": " << v.err;
    };
    for (const char* option : {"--coder rans", "--coder raw", "--raw"}) roundTrips(option);
    for (int w = 0; w <= 4; ++w) roundTrips("--shape-eighths " + std::to_string(w));
}

TEST(PtmCli, PrefixesAndDamagedFiles) {
    const fs::path png = writeTexture("bad.png", 3), ptm = ptmDir() / "bad.ptm";
    ASSERT_EQ(runParallax("ptm encode " + png.string() + " -o " + ptm.string()).exitCode, 0);
    const std::string bytes = readAll(ptm);
    auto doc = nlohmann::json::parse(runParallax("ptm info " + ptm.string() + " --json").out);
    const uint64_t level2End = doc["level_groups"][2]["offset"].get<uint64_t>() +
                               doc["level_groups"][2]["bytes"].get<uint64_t>();

    // A prefix that holds levels 0-2: info says so, level 2 decodes, level 3 does not.
    const fs::path prefix = ptmDir() / "prefix.ptm";
    writeFile(prefix, bytes.substr(0, level2End));
    auto part =
        nlohmann::json::parse(runParallax("ptm info " + prefix.string() + " --json --partial").out);
    EXPECT_FALSE(part["file_complete"].get<bool>());
    EXPECT_TRUE(part["level_groups"][2]["complete"].get<bool>());
    EXPECT_FALSE(part["level_groups"][3]["complete"].get<bool>());
    // Without --partial a prefix is a truncated file, and info says so.
    expectOneLineError(runParallax("ptm info " + prefix.string()),
                       "is truncated: " + std::to_string(level2End) + " of the " +
                           std::to_string(bytes.size()) +
                           " bytes its header declares (levels "
                           "0..2 of 0..6 complete");
    const fs::path out = ptmDir() / "prefix.png";
    EXPECT_EQ(
        runParallax("ptm decode " + prefix.string() + " --level 2 -o " + out.string()).exitCode, 0);
    expectOneLineError(
        runParallax("ptm decode " + prefix.string() + " --level 3 -o " + out.string()),
        "prefix.ptm: PTM: file truncated in level 3");

    // Damage in the last group: its checksum names it.
    std::string damaged = bytes;
    damaged[damaged.size() - 5] = char(damaged[damaged.size() - 5] ^ 0x40);
    const fs::path bad = ptmDir() / "damaged.ptm";
    writeFile(bad, damaged);
    expectOneLineError(runParallax("ptm verify " + bad.string()), "level 6 checksum mismatch");

    const fs::path shortFile = ptmDir() / "short.ptm";
    writeFile(shortFile, bytes.substr(0, 20));
    expectOneLineError(runParallax("ptm info " + shortFile.string()), "PTM");
    expectOneLineError(runParallax("ptm info " + (ptmDir() / "none.ptm").string()), "none.ptm");
    expectOneLineError(runParallax("ptm encode " + ptm.string() + " -o x.ptm"), "bad.ptm");
    expectOneLineError(runParallax("ptm verify " + ptm.string() + " --against " +
                                   writeTexture("other.png", 4).string()),
                       "does not decode to");
    expectOneLineError(runParallax("ptm decode " + ptm.string() + " --level 7 -o " + out.string()),
                       "--level 7 outside 0..6", 2);
    // Version 1's other coders are gone: by name or number, a one-line usage error that names
    // the option and the coders left.
    for (const char* removed : {"6", "zstd", "predict+zstd", "predict-cross+rans-simd"}) {
        expectOneLineError(
            runParallax("ptm encode " + png.string() + " -o x.ptm --coder " + removed),
            "--coder: " + std::string(removed) + " not in {rans,raw}", 2);
    }
    expectOneLineError(runParallax("ptm encode " + png.string() + " -o x.ptm --zstd"), "--zstd",
                       2);
    // A version 1 file: one line that names the version and says to re-encode.
    const std::string v1 = std::string(PLX_SOURCE_DIR) + "/tests/golden/ptm/v1_rgb_70x9.ptm";
    for (const char* command : {"ptm info ", "ptm verify "})
        expectOneLineError(runParallax(command + v1), "version 1 is no longer supported");
    EXPECT_EQ(runParallax("ptm encode " + png.string() + " -o x.ptm --shape-eighths 5").exitCode,
              2);
}

// -o naming the input, or a link to it, is refused before anything is written: the input stays.
TEST(PtmCli, OutputThatIsTheInputIsRefused) {
    const fs::path png = writeTexture("same.png", 3), ptm = ptmDir() / "same.ptm";
    ASSERT_EQ(runParallax("ptm encode " + png.string() + " -o " + ptm.string()).exitCode, 0);
    const std::string pngBytes = readAll(png), ptmBytes = readAll(ptm);
    const fs::path link = ptmDir() / "same-link.png";
    fs::remove(link);
    fs::create_symlink(png.filename(), link);
    for (const fs::path& out : {png, link})
        expectOneLineError(runParallax("ptm encode " + png.string() + " -o " + out.string()),
                           "is the input file", 2);
    expectOneLineError(runParallax("ptm decode " + ptm.string() + " -o " + ptm.string()),
                       "is the input file", 2);
    EXPECT_EQ(readAll(png), pngBytes);
    EXPECT_EQ(readAll(ptm), ptmBytes);
}

}  // namespace
