// readFileChecked refuses everything but regular files, without blocking, and names the cause.

#include <filesystem>
#include <fstream>

#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <plx/core/file.h>
#include <plx/core/image_io.h>

namespace plx {
namespace {

namespace fs = std::filesystem;

fs::path tempDir(const std::string& name) {
    fs::path dir = fs::path(PLX_TEST_OUTPUT_DIR) / "core_file" / name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
}

void expectRefused(const std::string& path, const std::string& cause) {
    auto r = readFileChecked(path);
    ASSERT_FALSE(r.isOk()) << path;
    EXPECT_NE(r.status().message().find(cause), std::string::npos) << r.status().message();
    EXPECT_NE(r.status().message().find(path), std::string::npos) << r.status().message();
    EXPECT_EQ(r.status().message().find('\n'), std::string::npos);
    // readFileBytes, which every module uses, goes through the same checks.
    EXPECT_FALSE(readFileBytes(path).isOk());
}

TEST(FileChecked, ReadsRegularFiles) {
    fs::path p = tempDir("regular") / "a.bin";
    std::ofstream(p, std::ios::binary) << std::string("ab\0cd", 5);
    auto r = readFileChecked(p.string());
    ASSERT_TRUE(r.isOk()) << r.status().message();
    EXPECT_EQ(*r, std::string("ab\0cd", 5));
    EXPECT_EQ(*checkRegularFile(p.string()), 5u);
}

TEST(FileChecked, RefusesDirectoriesFifosAndDevices) {
    fs::path dir = tempDir("kinds");
    expectRefused(dir.string(), "directory");
    fs::path fifo = dir / "fifo";
    ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
    // Opened without a writer: O_NONBLOCK makes this return at once instead of hanging.
    expectRefused(fifo.string(), "FIFO");
    expectRefused("/dev/zero", "character device");
}

TEST(FileChecked, NamesTheCauseOfAFailedOpen) {
    fs::path dir = tempDir("causes");
    expectRefused((dir / "missing.bin").string(), "not found");
    fs::create_symlink(dir / "loop_b", dir / "loop_a");
    fs::create_symlink(dir / "loop_a", dir / "loop_b");
    expectRefused((dir / "loop_a").string(), "symlink loop");
    fs::path file = dir / "plain";
    std::ofstream(file) << "x";
    expectRefused((file / "below").string(), "not a directory");
    if (geteuid() != 0) {  // root reads anything: the permission check cannot fail there
        fs::permissions(file, fs::perms::none);
        expectRefused(file.string(), "permission denied");
    }
}

TEST(FileChecked, LineColumnOfAnOffset) {
    const std::string text = "ab\ncde\n\nf";
    EXPECT_EQ(lineColumn(text, 0), "line 1, column 1");
    EXPECT_EQ(lineColumn(text, 2), "line 1, column 3");
    EXPECT_EQ(lineColumn(text, 3), "line 2, column 1");
    EXPECT_EQ(lineColumn(text, 8), "line 4, column 1");
    EXPECT_EQ(lineColumn(text, 99), "line 4, column 2");
}

TEST(FileChecked, RefusesFilesOverTheLimit) {
    fs::path p = tempDir("limit") / "big.bin";
    std::ofstream(p, std::ios::binary) << std::string(100, 'x');
    auto r = readFileChecked(p.string(), 99);
    ASSERT_FALSE(r.isOk());
    EXPECT_EQ(r.status().code(), ErrorCode::kOutOfRange);
    EXPECT_NE(r.status().message().find("limit of 99"), std::string::npos);
    EXPECT_TRUE(readFileChecked(p.string(), 100).isOk());
}

}  // namespace
}  // namespace plx

namespace plx {
namespace {

void be32(std::vector<uint8_t>* v, uint32_t x) {
    for (int s = 24; s >= 0; s -= 8) v->push_back(uint8_t(x >> s));
}

// Appends one PNG chunk: length, type, data, CRC-32 of type and data.
void pngChunk(std::vector<uint8_t>* png, const char* type, const std::vector<uint8_t>& data) {
    std::vector<uint8_t> body(type, type + 4);
    body.insert(body.end(), data.begin(), data.end());
    uint32_t crc = 0xFFFFFFFFu;
    for (uint8_t b : body) {
        crc ^= b;
        for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    be32(png, uint32_t(data.size()));
    png->insert(png->end(), body.begin(), body.end());
    be32(png, ~crc);
}

// A PNG whose header declares width x height grey pixels and whose image data is empty: enough
// for a decoder to learn the size, which is all the pixel limit needs.
std::vector<uint8_t> pngHeaderOnly(uint32_t width, uint32_t height) {
    std::vector<uint8_t> ihdr;
    be32(&ihdr, width);
    be32(&ihdr, height);
    ihdr.insert(ihdr.end(), {8, 0, 0, 0, 0});  // 8-bit grey, no interlace
    std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
    pngChunk(&png, "IHDR", ihdr);
    pngChunk(&png, "IDAT", {});
    pngChunk(&png, "IEND", {});
    return png;
}

TEST(ImageIoLimits, DeclaredPixelsOverTheLimitAreRefusedBeforeDecoding) {
    // 16384 x 16384 zeros compress to under a megabyte and would decode to 256 MiB.
    auto big = decodeImage(pngHeaderOnly(16384, 16384));
    ASSERT_FALSE(big.isOk());
    EXPECT_EQ(big.status().code(), ErrorCode::kOutOfRange);
    EXPECT_NE(big.status().message().find("limit of 67108864 pixels"), std::string::npos)
        << big.status().message();
    // A lower limit refuses smaller images too; under the limit the decoder goes on (and fails
    // here only because the pixels are missing).
    auto small = decodeImage(pngHeaderOnly(100, 100), 99 * 100);
    EXPECT_EQ(small.status().code(), ErrorCode::kOutOfRange);
    auto allowed = decodeImage(pngHeaderOnly(100, 100), 100 * 100);
    EXPECT_NE(allowed.status().code(), ErrorCode::kOutOfRange);
}

}  // namespace
}  // namespace plx
