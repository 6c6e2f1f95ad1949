#include <atomic>
#include <filesystem>
#include <random>
#include <thread>
#include <tuple>

#include <gtest/gtest.h>

#include <plx/core/image_io.h>
#include <plx/ptm/ptm.h>

#include "hostile_files.h"

namespace plx::ptm {
namespace {

ByteImage randomImage(int w, int h, int c, uint32_t seed, bool smooth) {
    std::mt19937 rng(seed);
    ByteImage img{w, h, c, std::vector<uint8_t>(size_t(w) * h * c)};
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            for (int k = 0; k < c; ++k) {
                int v = smooth ? (x * 7 + y * 3 + k * 40 + int(rng() % 9)) & 255 : int(rng() & 255);
                img.pixel(x, y)[k] = uint8_t(v);
            }
    return img;
}

// Reference of eq. (1): pad the level by replicating its last row/column to even size, then
// floor of the mean of each 2x2 block. Written independently of boxReduce.
ByteImage referenceReduce(const ByteImage& in) {
    ByteImage out{(in.width + 1) / 2, (in.height + 1) / 2, in.channels, {}};
    out.bytes.resize(size_t(out.width) * out.height * in.channels);
    auto at = [&](int x, int y, int k) {
        return int(in.pixel(std::min(x, in.width - 1), std::min(y, in.height - 1))[k]);
    };
    for (int y = 0; y < out.height; ++y)
        for (int x = 0; x < out.width; ++x)
            for (int k = 0; k < in.channels; ++k)
                out.pixel(x, y)[k] = uint8_t((at(2 * x, 2 * y, k) + at(2 * x + 1, 2 * y, k) +
                                              at(2 * x, 2 * y + 1, k) +
                                              at(2 * x + 1, 2 * y + 1, k)) >> 2);
    return out;
}

std::vector<uint8_t> mustEncode(const ByteImage& img, EncodeConfig config = {}) {
    auto file = encode(img, config);
    EXPECT_TRUE(file.isOk()) << file.status().toString();
    return file.isOk() ? std::move(file).value() : std::vector<uint8_t>{};
}

TEST(PtmMip, BoxReduceMatchesPaddedReference) {
    for (auto [w, h] : {std::pair{1, 1}, {2, 2}, {3, 1}, {1, 5}, {7, 4}, {9, 13}}) {
        for (int c = 1; c <= 4; ++c) {
            ByteImage img = randomImage(w, h, c, uint32_t(w * 100 + h + c), false);
            EXPECT_EQ(boxReduce(img), referenceReduce(img)) << w << "x" << h << " c" << c;
        }
    }
}

// crc32 (carry-less multiplication where built with it) against the table reference and the
// standard check value, over lengths around the 16- and 64-byte folding steps and unaligned
// starts; continuing a CRC equals one pass.
TEST(PtmFormat, Crc32MatchesPortableReference) {
    const std::string check = "123456789";
    const auto* cp = reinterpret_cast<const uint8_t*>(check.data());
    EXPECT_EQ(crc32(std::span(cp, check.size())), 0xCBF43926u);
    EXPECT_EQ(crc32Portable(std::span(cp, check.size())), 0xCBF43926u);
    std::mt19937 rng(7);
    std::vector<uint8_t> data(4096 + 64);
    for (auto& b : data) b = uint8_t(rng());
    for (size_t n : {0, 1, 15, 16, 63, 64, 65, 79, 80, 127, 128, 129, 200, 1000, 4096})
        for (size_t off : {0, 1, 3, 8}) {
            const auto s = std::span(data).subspan(off, n);
            ASSERT_EQ(crc32(s), crc32Portable(s)) << n << " bytes at offset " << off;
            ASSERT_EQ(crc32(s, 0x12345678u), crc32Portable(s, 0x12345678u));
            const size_t h = n / 3;
            ASSERT_EQ(crc32(s.subspan(h), crc32(s.first(h))), crc32(s));
        }
}

TEST(PtmMip, ChainLengths) {
    EXPECT_EQ(fullChainLength(1, 1), 1);
    EXPECT_EQ(fullChainLength(1024, 1024), 11);
    EXPECT_EQ(fullChainLength(5, 1), 4);  // 5, 3, 2, 1
    auto sizes = levelSizes(13, 7, 4);
    ASSERT_EQ(sizes.size(), 4u);
    EXPECT_EQ(sizes[0], (LevelSize{2, 1}));
    EXPECT_EQ(sizes[3], (LevelSize{13, 7}));
}

TEST(PtmCodec, RoundTripManySizesAndComponents) {
    const std::pair<int, int> sizes[] = {{1, 1}, {2, 1}, {1, 2}, {2, 2}, {3, 3}, {5, 1},
                                         {1, 9}, {13, 7}, {17, 33}, {64, 64}, {127, 3},
                                         {3, 127}, {100, 61}, {256, 1}};
    for (auto [w, h] : sizes)
        for (int c = 1; c <= 4; ++c)
            for (Coder coder : {Coder::kRaw, Coder::kRans})
                for (bool smooth : {false, true}) {
                    ByteImage img = randomImage(w, h, c, uint32_t(w * 31 + h * 7 + c), smooth);
                    EncodeConfig cfg;
                    cfg.coder = coder;
                    auto file = mustEncode(img, cfg);
                    auto back = decodeImage(file);
                    ASSERT_TRUE(back.isOk()) << back.status().toString();
                    EXPECT_EQ(*back, img) << w << "x" << h << " c" << c;
                }
}

TEST(PtmCodec, ExtremeValuesRoundTrip) {
    for (uint8_t v : {uint8_t(0), uint8_t(255)}) {
        ByteImage img{33, 17, 4, std::vector<uint8_t>(33 * 17 * 4, v)};
        img.bytes[5] = uint8_t(255 - v);
        auto back = decodeImage(mustEncode(img));
        ASSERT_TRUE(back.isOk());
        EXPECT_EQ(*back, img);
    }
}

TEST(PtmCodec, EachLevelAloneEqualsBoxFilteredMip) {
    ByteImage img = randomImage(45, 30, 3, 7, true);
    auto file = mustEncode(img);
    auto header = parseHeader(file);
    ASSERT_TRUE(header.isOk());
    ASSERT_EQ(header->levelCount, fullChainLength(45, 30));
    ByteImage expected = img;
    for (int k = header->levelCount - 1; k >= 0; --k) {
        // Only the prefix up to the end of group k is given.
        const ByteRange r = levelByteRange(*header, k);
        auto level = decodeLevel(std::span(file).first(size_t(r.offset + r.size)), k);
        ASSERT_TRUE(level.isOk()) << level.status().toString();
        EXPECT_EQ(*level, expected) << "level " << k;
        expected = referenceReduce(expected);
    }
}

TEST(PtmCodec, LowestLevelIsConfigurable) {
    ByteImage img = randomImage(40, 24, 2, 3, true);
    for (int side : {1, 2, 5, 10, 24, 40, 1000}) {
        EncodeConfig cfg;
        cfg.lowestMaxSide = side;
        auto file = mustEncode(img, cfg);
        auto header = parseHeader(file);
        ASSERT_TRUE(header.isOk());
        EXPECT_LE(std::max(header->lowest.width, header->lowest.height), side);
        EXPECT_EQ(header->levelCount, storedLevelCount(40, 24, cfg));
        auto back = decodeImage(file);
        ASSERT_TRUE(back.isOk());
        EXPECT_EQ(*back, img);
    }
    EncodeConfig bad;
    bad.lowestMaxSide = 0;
    EXPECT_FALSE(encode(img, bad).isOk());
}

TEST(PtmDecoder, ProgressiveGroupsInOrder) {
    ByteImage img = randomImage(70, 50, 4, 11, true);
    auto file = mustEncode(img);
    auto header = parseHeader(file);
    ASSERT_TRUE(header.isOk());
    // Only the header bytes at first, as a client fetching with Range requests would.
    auto dec = ProgressiveDecoder::create(std::span(file).first(header->headerBytes()));
    ASSERT_TRUE(dec.isOk());
    std::vector<ByteImage> chain = buildMipChain(img, header->levelCount);
    uint64_t expectedOffset = header->headerBytes();
    for (int k = 0; k < header->levelCount; ++k) {
        const ByteRange r = levelByteRange(dec->header(), k);
        EXPECT_EQ(r.offset, expectedOffset);
        expectedOffset += r.size;
        ASSERT_TRUE(dec->addGroup(std::span(file).subspan(r.offset, r.size)).isOk());
        EXPECT_EQ(dec->level(k), chain[size_t(k)]);
    }
    EXPECT_TRUE(dec->complete());
    EXPECT_EQ(expectedOffset, file.size());
}

// The decode tables live in one buffer per thread (decoder.cpp): threads decoding at once get
// their own, and a thread's buffer serves groups of every size in any order (it grows to the
// largest and keeps it).
TEST(PtmDecoder, ThreadsDecodeWithTheirOwnTables) {
    const ByteImage small = randomImage(70, 9, 1, 31, true);
    const ByteImage large = randomImage(300, 170, 4, 32, true);
    const std::vector<uint8_t> files[2] = {mustEncode(small), mustEncode(large)};
    const ByteImage* images[2] = {&small, &large};
    std::atomic<int> wrong{0};
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t)
        threads.emplace_back([&, t] {
            for (int i = 0; i < 6; ++i) {  // small and large alternate, each thread in its order
                const int which = (i + t) % 2;
                auto decoded = decodeImage(files[which]);
                if (!decoded || *decoded != *images[which]) ++wrong;
            }
        });
    for (auto& thread : threads) thread.join();
    EXPECT_EQ(wrong.load(), 0);
}

TEST(PtmDecoder, WrongGroupIsRejected) {
    auto file = mustEncode(randomImage(20, 20, 3, 5, true));
    auto dec = ProgressiveDecoder::create(file);
    ASSERT_TRUE(dec.isOk());
    const ByteRange r1 = levelByteRange(dec->header(), 1);
    Status s = dec->addGroup(std::span(file).subspan(r1.offset, r1.size));  // group 1 first
    EXPECT_FALSE(s.isOk());
    EXPECT_NE(s.message().find("level 0"), std::string::npos) << s.message();
}

TEST(PtmDecoder, EveryTruncatedPrefixFailsCleanly) {
    for (Coder coder : {Coder::kRaw, Coder::kRans}) {
        EncodeConfig cfg;
        cfg.coder = coder;
        // Wide enough for the vectorised rounds of 32 symbols (runs of 35, on an image whose top
        // level is modelled rather than stored).
        auto file = coder == Coder::kRans ? mustEncode(randomImage(70, 10, 3, 5, true), cfg)
                                          : mustEncode(randomImage(23, 11, 4, 9, true), cfg);
        auto header = parseHeader(file);
        ASSERT_TRUE(header.isOk());
        for (size_t n = 0; n < file.size(); ++n) {
            std::span<const uint8_t> prefix(file.data(), n);
            auto img = decodeImage(prefix);
            EXPECT_FALSE(img.isOk()) << "prefix " << n;
            if (!img.isOk()) {
                EXPECT_FALSE(img.status().message().empty());
            }
            // Levels wholly inside the prefix decode; the others fail with an error.
            for (int k = 0; k < header->levelCount; ++k) {
                const ByteRange r = levelByteRange(*header, k);
                auto level = decodeLevel(prefix, k);
                EXPECT_EQ(level.isOk(), r.offset + r.size <= n) << "prefix " << n << " level " << k;
            }
        }
    }
}

TEST(PtmDecoder, HostileGroupsWithValidChecksumsNeverCrash) {
    // Every byte of every group flipped, CRCs fixed up: the entropy decoder must stay in bounds
    // (ASan/UBSan runs check it) and usually report the damage. The image is wide enough for the
    // vectorised rounds (runs of 35 symbols); a 35x5 lowest level makes group 0 modelled too.
    EncodeConfig cfg;
    cfg.lowestMaxSide = 35;
    auto file = mustEncode(randomImage(70, 10, 3, 5, true), cfg);
    auto h = parseHeader(file);
    ASSERT_TRUE(h.isOk());
    int detected = 0, total = 0;
    for (int k = 0; k < h->levelCount; ++k) {
        for (size_t i = 0; i < levelByteRange(*h, k).size; ++i) {
            for (uint8_t flip : {uint8_t(0x01), uint8_t(0x80)}) {
                auto out = decodeImage(corruptGroup(file, k, i, flip));
                ++total;
                // A flip in the table of an unused context changes nothing: then the image
                // decodes unchanged, which is fine.
                if (!out.isOk()) {
                    ++detected;
                    EXPECT_FALSE(out.status().message().empty());
                }
            }
        }
    }
    EXPECT_GT(detected, total / 2) << detected << " of " << total;
}

TEST(PtmCodec, ShapeWeights) {
    // Every shape weight round-trips and is stored in each modelled group's first byte,
    // the default search is not larger than a fixed weight it tries, and the decoder names a weight
    // out of range. Smooth and noisy images, 3 and 4 components (the mean of two components'
    // residuals), wide enough for the vector path.
    for (int c : {3, 4})
        for (bool smooth : {false, true}) {
            const ByteImage img = randomImage(75, 21, c, uint32_t(11 + c), smooth);
            EncodeConfig cfg;
            const size_t searched = mustEncode(img, cfg).size();
            for (int w = 0; w <= 4; ++w) {
                cfg.shapeEighths = w;
                auto file = mustEncode(img, cfg);
                auto h = parseHeader(file);
                ASSERT_TRUE(h.isOk());
                // The search picks each level's weight by its estimated size (the rANS stream's
                // rounding aside), so it may lose a few bytes per level to a weight it tries.
                if (w != 1) {
                    EXPECT_LE(searched, file.size() + 4 * size_t(h->levelCount)) << "weight " << w;
                }
                for (int k = 1; k < h->levelCount; ++k) {  // modelled with w, or stored
                    const uint8_t mode = file[levelByteRange(*h, k).offset];
                    EXPECT_TRUE(mode == w || mode == 0xFF) << "level " << k << ": " << int(mode);
                }
                const uint8_t topMode = file[levelByteRange(*h, h->levelCount - 1).offset];
                EXPECT_EQ(topMode, smooth ? w : 0xFF);  // noise is stored
                auto back = decodeImage(file);
                ASSERT_TRUE(back.isOk()) << back.status().toString();
                EXPECT_EQ(*back, img) << "weight " << w << " c" << c;
                if (w != 4 || !smooth) continue;
                const int k = h->levelCount - 1;
                auto bad = decodeImage(corruptGroup(file, k, 0, 0x01));  // weight 5
                ASSERT_FALSE(bad.isOk());
                EXPECT_NE(bad.status().message().find("shape weight 5 outside 0..4"),
                          std::string::npos)
                    << bad.status().message();
            }
        }
    EncodeConfig bad;
    bad.shapeEighths = 5;
    EXPECT_FALSE(encode(randomImage(4, 4, 3, 1, false), bad).isOk());
}

TEST(PtmCodec, StoresGroupsThatModellingWouldEnlarge) {
    // The modelled coder stores a group as coder kRaw's payload (mode byte 0xFF) where that is
    // smaller: the smallest levels, and every level of noise. Each group is then at most one
    // byte over kRaw's, and the decoder checks a stored group's length.
    for (bool smooth : {false, true}) {
        const ByteImage img = randomImage(48, 40, 3, 21, smooth);
        EncodeConfig raw;
        raw.coder = Coder::kRaw;
        const auto rawFile = mustEncode(img, raw);
        const auto file = mustEncode(img);
        auto h = parseHeader(file), rh = parseHeader(rawFile);
        ASSERT_TRUE(h.isOk() && rh.isOk());
        int stored = 0;
        for (int k = 0; k < h->levelCount; ++k) {
            const ByteRange r = levelByteRange(*h, k);
            EXPECT_LE(r.size, levelByteRange(*rh, k).size + 1) << "level " << k;
            stored += file[r.offset] == 0xFF ? 1 : 0;
        }
        EXPECT_GE(stored, smooth ? 1 : h->levelCount) << "smooth " << smooth;
        auto back = decodeImage(file);
        ASSERT_TRUE(back.isOk()) << back.status().toString();
        EXPECT_EQ(*back, img);
        if (smooth) continue;
        // Level 0 stored (mode byte, 3 pixel bytes): its last byte dropped, CRC and index fixed.
        auto cut = file;
        const ByteRange r0 = levelByteRange(*h, 0);
        cut.erase(cut.begin() + std::ptrdiff_t(r0.offset + r0.size - 1));
        auto hc = *h;
        hc.groups[0].size -= 1;
        for (size_t k = 1; k < hc.groups.size(); ++k) hc.groups[k].offset -= 1;
        hc.groups[0].crc32 = crc32(std::span(cut).subspan(r0.offset, r0.size - 1));
        const auto header = writeHeader(hc);
        std::copy(header.begin(), header.end(), cut.begin());
        auto bad = decodeImage(cut);
        ASSERT_FALSE(bad.isOk());
        EXPECT_NE(bad.status().message().find("level 0 raw group has 2 bytes, needs 3"),
                  std::string::npos)
            << bad.status().message();
    }
}

TEST(PtmDecoder, EverySingleByteCorruptionIsDetected) {
    auto file = mustEncode(randomImage(19, 9, 3, 4, true));
    for (size_t i = 0; i < file.size(); ++i) {
        for (uint8_t flip : {uint8_t(0x01), uint8_t(0x80), uint8_t(0xFF)}) {
            auto bad = file;
            bad[i] ^= flip;
            EXPECT_FALSE(decodeImage(bad).isOk()) << "byte " << i;
        }
    }
}

// Rewrites the header of a valid file with a field changed and a correct header CRC, as a
// hostile file would.
std::vector<uint8_t> forge(std::vector<uint8_t> file, size_t at, std::vector<uint8_t> bytes) {
    std::copy(bytes.begin(), bytes.end(), file.begin() + ptrdiff_t(at));
    auto h = parseHeader(file);  // may fail on the CRC; recompute it from the level count
    const size_t headerBytes = headerBytesFor(file[20]);
    if (headerBytes <= file.size()) {
        uint32_t c = crc32(std::span(file).first(headerBytes - 4));
        for (int i = 0; i < 4; ++i) file[headerBytes - 4 + size_t(i)] = uint8_t(c >> (8 * i));
    }
    (void)h;
    return file;
}

TEST(PtmDecoder, HostileHeadersReturnErrors) {
    auto file = mustEncode(randomImage(16, 16, 3, 2, true));
    struct Case {
        size_t at;
        std::vector<uint8_t> bytes;
        const char* expect;
    };
    const Case cases[] = {
        {12, {0xFF, 0xFF, 0xFF, 0x7F}, "size"},    // width 2^31 - 1
        {16, {0x01, 0x80, 0x00, 0x00}, "size"},    // height 32769, over kMaxSide
        {10, {0x07}, "component"},                 // 7 components
        {11, {0x02}, "coder"},                     // unknown coder
        {20, {0x40}, "level count"},               // 64 levels
        {24, {0x03}, "lowest"},                    // lowest level width wrong
        {32, {0x00, 0x00, 0x10}, "offset"},        // group 0 offset wrong
        {40, {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF}, "size"},  // group 0 size huge
        {8, {0x03}, "version"},
        {0, {'X'}, "magic"},
    };
    for (const Case& c : cases) {
        auto bad = forge(file, c.at, c.bytes);
        auto img = decodeImage(bad);
        ASSERT_FALSE(img.isOk()) << c.expect;
        EXPECT_NE(img.status().message().find(c.expect), std::string::npos)
            << img.status().message();
    }
    auto bad = file;
    bad[40] ^= 1;  // header CRC no longer matches
    auto img = decodeImage(bad);
    ASSERT_FALSE(img.isOk());
    EXPECT_NE(img.status().message().find("checksum"), std::string::npos);
}

TEST(PtmDecoder, BadEpsilonWithValidChecksumIsRejected) {
    // A raw file edited consistently (CRC recomputed) with an epsilon that eq. (3) cannot accept.
    EncodeConfig cfg;
    cfg.coder = Coder::kRaw;
    ByteImage img{2, 2, 1, {0, 0, 0, 0}};
    auto file = mustEncode(img, cfg);
    auto header = parseHeader(file);
    ASSERT_TRUE(header.isOk());
    ASSERT_EQ(header->levelCount, 2);
    const ByteRange r = levelByteRange(*header, 1);
    file[r.offset] = 3;                      // eps = 3, so p11 = 0 + 3 - 0 = 3: legal
    file[r.offset + 1] = 200;                // p00 = 200: p11 = 3 - 200 < 0, impossible
    uint32_t c = crc32(std::span(file).subspan(r.offset, r.size));
    const size_t entry = kFixedHeaderBytes + kIndexEntryBytes + 16;
    for (int i = 0; i < 4; ++i) file[entry + size_t(i)] = uint8_t(c >> (8 * i));
    file = forge(file, 0, {0x89});
    auto out = decodeImage(file);
    ASSERT_FALSE(out.isOk());
    EXPECT_NE(out.status().message().find("out of range"), std::string::npos)
        << out.status().message();
}

// The frozen bitstream: a 13x7 RGBA image of fixed content, and a 70x9 RGB one whose top
// level's runs (35 symbols) reach the vectorised rounds.
ByteImage goldenImage() {
    ByteImage img{13, 7, 4, std::vector<uint8_t>(13 * 7 * 4)};
    for (int y = 0; y < 7; ++y)
        for (int x = 0; x < 13; ++x)
            for (int k = 0; k < 4; ++k)
                img.pixel(x, y)[k] = uint8_t((x * 37 + y * 11 + k * 61 + x * y * 5) % 256);
    return img;
}

ByteImage goldenWideImage() {
    ByteImage img{70, 9, 3, std::vector<uint8_t>(70 * 9 * 3)};
    for (int y = 0; y < 9; ++y)
        for (int x = 0; x < 70; ++x)
            for (int k = 0; k < 3; ++k)
                img.pixel(x, y)[k] = uint8_t((x * 3 + y * 7 + k * 29 + (x * y * 13) % 17) % 256);
    return img;
}

TEST(PtmGolden, FrozenBitstream) {
    const std::string dir = std::string(PLX_SOURCE_DIR) + "/tests/golden/ptm/";
    EncodeConfig raw;
    raw.coder = Coder::kRaw;
    EncodeConfig rans;
    // The modelled coder stores most small groups raw (both 13x7 files' groups and all but the
    // top level of the 70x9 one); with a 35x5 lowest level, level 0 is modelled too.
    EncodeConfig ransLowest35;
    ransLowest35.lowestMaxSide = 35;
    const std::tuple<const char*, std::vector<uint8_t>, ByteImage> files[] = {
        {"rgba_13x7_raw.ptm", mustEncode(goldenImage(), raw), goldenImage()},
        {"rgba_13x7_rans.ptm", mustEncode(goldenImage(), rans), goldenImage()},
        {"rgb_70x9_rans.ptm", mustEncode(goldenWideImage(), rans), goldenWideImage()},
        {"rgb_70x9_rans_lowest35.ptm", mustEncode(goldenWideImage(), ransLowest35),
         goldenWideImage()},
    };
    for (const auto& [name, file, image] : files) {
        if (std::getenv("PLX_UPDATE_GOLDEN")) {
            ASSERT_TRUE(writeFileBytes(dir + name, file).isOk());
        }
        auto golden = readFileBytes(dir + name);
        ASSERT_TRUE(golden.isOk()) << "golden file missing in " << dir;
        EXPECT_EQ(file, *golden) << "the bitstream changed: " << name;
        auto back = decodeImage(*golden);
        ASSERT_TRUE(back.isOk()) << back.status().toString();
        EXPECT_EQ(*back, image) << name;
    }
}

// Version 1 files (seven coders) are refused with a message that names the version and says
// what to do, never decoded: the committed one and a fresh file with its version field set to 1.
TEST(PtmGolden, VersionOneIsRefused) {
    const std::string dir = std::string(PLX_SOURCE_DIR) + "/tests/golden/ptm/";
    auto v1 = readFileBytes(dir + "v1_rgb_70x9.ptm");
    ASSERT_TRUE(v1.isOk()) << "golden file missing in " << dir;
    const auto forged = forge(mustEncode(goldenWideImage()), 8, {0x01});
    for (const auto& file : {*v1, forged}) {
        auto out = decodeImage(file);
        ASSERT_FALSE(out.isOk());
        EXPECT_EQ(out.status().code(), ErrorCode::kUnsupported);
        EXPECT_EQ(out.status().message(),
                  "PTM format version 1 is no longer supported: re-encode with this version (2)");
        EXPECT_FALSE(ProgressiveDecoder::create(file).isOk());
    }
}

TEST(PtmCodec, SponzaTexturesRoundTrip) {
    const std::filesystem::path dir = std::filesystem::path(PLX_SHARED_DATA_DIR) /
                                      "textures/sponza";
    if (!std::filesystem::exists(dir)) GTEST_SKIP() << "no Sponza textures in " << dir;
    std::vector<std::filesystem::path> files;
    for (const auto& e : std::filesystem::directory_iterator(dir))
        if (e.path().extension() == ".jpg" || e.path().extension() == ".png")
            files.push_back(e.path());
    std::sort(files.begin(), files.end());
    if (files.size() > 3) files.resize(3);
    for (const auto& f : files) {
        auto img = readImage(f.string());
        ASSERT_TRUE(img.isOk()) << img.status().toString();
        auto file = mustEncode(*img);
        auto back = decodeAllLevels(file);
        ASSERT_TRUE(back.isOk()) << back.status().toString();
        EXPECT_EQ(back->back(), *img) << f;
        EXPECT_EQ(*back, buildMipChain(*img, int(back->size()))) << f;
    }
}

}  // namespace
}  // namespace plx::ptm
