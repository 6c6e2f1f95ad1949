// White-box: the q16 disparity codec's per-ISA kernels (disparity_kernels.inl) against its
// pixel-by-pixel reference (disparity_q16_reference.cpp), byte for byte and float for float, on
// every path this process can run; and the row ranges the warp computes against
// std::minmax_element.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include <plx/core/cpu.h>
#include <plx/warp/reference.h>

#include "disparity_q16_codes.h"
#include "payloads.h"
#include "test_sets.h"

namespace plx::remote {
namespace {

// Rendered faces (empty sky, planes, edges) and random images: widths not a multiple of any
// vector, runs of empty pixels, values on and just off the code boundaries, a one-value image.
std::vector<Image<float>> disparityImages() {
    std::vector<Image<float>> images;
    for (const char* spec : {"office:1", "museum:1"})
        for (const warp::ReferenceView& v : renderedSet(spec, 96).views)
            images.push_back(v.disparity);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> value(0.01f, 2.0f);
    for (int w : {1, 2, 3, 17, 61}) {
        Image<float> img(w, 13);
        for (size_t i = 0; i < img.pixelCount(); ++i) {
            const uint32_t r = rng();
            img.data()[i] = r % 5 == 0 ? 0.0f : (r % 7 == 0 ? 1.0f : value(rng));
        }
        images.push_back(std::move(img));
    }
    Image<float> flat(33, 4, 0.25f);
    flat.at(3, 1) = 0.0f;
    images.push_back(std::move(flat));
    images.emplace_back(9, 2, 0.0f);  // nothing drawn
    return images;
}

std::vector<float> rowBound(const Image<float>& img, bool max) {
    std::vector<float> out;
    for (int y = 0; y < img.height(); ++y) {
        const float* row = img.row(y);
        out.push_back(max ? *std::max_element(row, row + img.width())
                          : *std::min_element(row, row + img.width()));
    }
    return out;
}

// Runs `check` on each of disparityImages() on every ISA path this process can run.
template <class Check>
void onEveryIsaAndImage(Check check) {
    ActiveIsaGuard restore;
    const std::vector<Image<float>> images = disparityImages();
    for (Isa isa : runnableIsas()) {
        ASSERT_TRUE(setActiveIsa(isa).isOk());
        for (size_t i = 0; i < images.size(); ++i) {
            SCOPED_TRACE(std::string(isaName(isa)) + " image " + std::to_string(i));
            check(images[i]);
        }
    }
}

TEST(DisparityPaths, EveryKernelEqualsTheReference) {
    onEveryIsaAndImage([](const Image<float>& img) {
        const DisparityRange range = disparityRange(img);
        const DisparityRange expected = reference::disparityRange(img);
        ASSERT_EQ(range.dmin, expected.dmin);
        ASSERT_EQ(range.dmax, expected.dmax);
        std::vector<float> q16Floats;  // what kQuantized16 decodes to: every q16 codec's floats
        for (DisparityCodec codec :
             {DisparityCodec::kQuantized16, DisparityCodec::kQuantized16Deflate,
              DisparityCodec::kQuantized16Packed}) {
            SCOPED_TRACE(int(codec));
            std::vector<uint8_t> bytes, referenceBytes;
            ASSERT_TRUE(encodeDisparityQ16(img, range, codec, 3, &bytes).isOk());
            ASSERT_TRUE(
                reference::encodeDisparityQ16(img, range, codec, 3, &referenceBytes).isOk());
            ASSERT_EQ(bytes, referenceBytes);
            const std::vector<float> lo = rowBound(img, false), hi = rowBound(img, true);
            Image<float> out(img.width(), img.height()), referenceOut(img.width(), img.height());
            ASSERT_TRUE(decodeDisparityQ16(bytes, codec, range, lo, hi, &out).isOk());
            ASSERT_TRUE(
                reference::decodeDisparityQ16(bytes, codec, range, lo, hi, &referenceOut).isOk());
            ASSERT_EQ(std::memcmp(out.data(), referenceOut.data(), out.pixelCount() * 4), 0);
            if (q16Floats.empty()) q16Floats.assign(out.data(), out.data() + out.pixelCount());
            ASSERT_EQ(std::memcmp(out.data(), q16Floats.data(), out.pixelCount() * 4), 0);
        }
    });
}

// Residual planes of code rows built to reach every branch of the decoder: runs of empty
// pixels, ramps that run into 0 and 65535 (where the predictor clamps), random codes; and, as a
// hostile payload would be, random bytes.
std::vector<uint8_t> codeRowPlanes(int w, int h, std::mt19937& rng) {
    std::vector<uint16_t> codes(size_t(w) * size_t(h));
    for (int y = 0; y < h; ++y) {
        uint16_t* row = codes.data() + size_t(y) * size_t(w);
        for (int x = 0; x < w;) {
            const int run = 1 + int(rng() % 24);
            const int kind = int(rng() % 4);
            const int start = int(rng() % 65536), slope = int(rng() % 8193) - 4096;
            for (int i = 0; i < run && x < w; ++i, ++x) {
                row[x] = kind == 0   ? 0
                         : kind == 1 ? uint16_t(rng())
                                     : uint16_t(std::clamp(start + slope * i, 0, 65535));
            }
        }
    }
    const size_t n = codes.size();
    std::vector<uint8_t> planes(2 * n);
    int aboveFirst = 0;
    for (int y = 0; y < h; ++y) {
        const uint16_t* row = codes.data() + size_t(y) * size_t(w);
        for (int x = 0; x < w; ++x) {
            const uint16_t z = q16::zigzag(int(row[x]) - q16::predict(row, x, aboveFirst));
            planes[size_t(y) * size_t(w) + size_t(x)] = uint8_t(z);
            planes[n + size_t(y) * size_t(w) + size_t(x)] = uint8_t(z >> 8);
        }
        aboveFirst = row[0];
    }
    return planes;
}

TEST(DisparityPaths, EveryDecoderEqualsTheReferenceOnAnyPlanes) {
    ActiveIsaGuard restore;
    std::mt19937 rng(11);
    std::vector<std::vector<uint8_t>> cases;
    std::vector<int> widths;
    for (int w : {1, 2, 3, 9, 10, 17, 18, 64, 133}) {
        cases.push_back(codeRowPlanes(w, 7, rng));
        widths.push_back(w);
        std::vector<uint8_t> noise(size_t(w) * 7 * 2);
        for (uint8_t& b : noise) b = uint8_t(rng() % 3 == 0 ? rng() : 0);
        cases.push_back(std::move(noise));
        widths.push_back(w);
    }
    const DisparityRange range{0.125f, 2.0f};
    for (Isa isa : runnableIsas()) {
        ASSERT_TRUE(setActiveIsa(isa).isOk());
        for (size_t i = 0; i < cases.size(); ++i) {
            SCOPED_TRACE(std::string(isaName(isa)) + " case " + std::to_string(i));
            const int w = widths[i];
            std::vector<uint8_t> bytes, packed;
            ASSERT_TRUE(zstdCompress(cases[i], 1, &bytes).isOk());
            ASSERT_TRUE(reference::packQ16Planes(cases[i], w, 7, 1, &packed).isOk());
            const std::vector<float> lo(7, 0.25f), hi(7, 1.5f);
            Image<float> out(w, 7), referenceOut(w, 7), packedOut(w, 7);
            ASSERT_TRUE(decodeDisparityQ16(bytes, DisparityCodec::kQuantized16, range, lo, hi, &out)
                            .isOk());
            ASSERT_TRUE(reference::decodeDisparityQ16(bytes, DisparityCodec::kQuantized16, range,
                                                      lo, hi, &referenceOut)
                            .isOk());
            ASSERT_EQ(std::memcmp(out.data(), referenceOut.data(), out.pixelCount() * 4), 0);
            ASSERT_TRUE(decodeDisparityQ16(packed, DisparityCodec::kQuantized16Packed, range, lo,
                                           hi, &packedOut)
                            .isOk());
            ASSERT_EQ(std::memcmp(out.data(), packedOut.data(), out.pixelCount() * 4), 0);
        }
    }
}

// Values a caller's view could hold outside its range (the codec clamps them to codes 1 and
// 65535), NaN (code 1), infinities and -0 (not drawn), at every position of a vector.
TEST(DisparityPaths, EveryEncoderEqualsTheReferenceOnValuesOutsideTheRange) {
    ActiveIsaGuard restore;
    const float specials[] = {std::numeric_limits<float>::quiet_NaN(),
                              std::numeric_limits<float>::infinity(),
                              -std::numeric_limits<float>::infinity(),
                              -0.0f,
                              -1.0f,
                              0.0f,
                              1e-30f,
                              0.125f,
                              0.1250001f,
                              2.0f,
                              1e30f};
    Image<float> img(37, 5);
    std::mt19937 rng(5);
    for (size_t i = 0; i < img.pixelCount(); ++i)
        img.data()[i] = rng() % 2 ? specials[rng() % std::size(specials)]
                                  : 0.125f + float(rng() % 1000) * 0.001875f;
    for (Isa isa : runnableIsas()) {
        ASSERT_TRUE(setActiveIsa(isa).isOk());
        SCOPED_TRACE(isaName(isa));
        for (DisparityRange range : {DisparityRange{0.125f, 2.0f}, DisparityRange{0.5f, 0.5f}}) {
            for (DisparityCodec codec :
                 {DisparityCodec::kQuantized16, DisparityCodec::kQuantized16Packed}) {
                std::vector<uint8_t> bytes, referenceBytes;
                ASSERT_TRUE(encodeDisparityQ16(img, range, codec, 1, &bytes).isOk());
                ASSERT_TRUE(
                    reference::encodeDisparityQ16(img, range, codec, 1, &referenceBytes).isOk());
                ASSERT_EQ(bytes, referenceBytes);
            }
        }
    }
}

// The encoder's one pass for range and check: the range of disparityRange, and "inside" exactly
// when no pixel lies outside its row's bounds (a bound moved inwards, a NaN pixel).
TEST(DisparityPaths, RangeInRowsIsTheRangeAndTheCheck) {
    onEveryIsaAndImage([](const Image<float>& img) {
        const std::vector<float> lo = rowBound(img, false), hi = rowBound(img, true);
        bool inside = false;
        const DisparityRange range = disparityRangeInRows(img, lo, hi, &inside);
        const DisparityRange expected = reference::disparityRange(img);
        EXPECT_TRUE(inside);
        EXPECT_EQ(range.dmin, expected.dmin);
        EXPECT_EQ(range.dmax, expected.dmax);
        const int y = img.height() / 2;
        if (hi[size_t(y)] > lo[size_t(y)]) {
            std::vector<float> narrower = hi;
            narrower[size_t(y)] = std::nextafter(hi[size_t(y)], 0.0f);
            disparityRangeInRows(img, lo, narrower, &inside);
            EXPECT_FALSE(inside);
        }
        Image<float> withNan = img;
        withNan.at(img.width() - 1, y) = std::numeric_limits<float>::quiet_NaN();
        disparityRangeInRows(withNan, lo, hi, &inside);
        EXPECT_FALSE(inside);
    });
}

TEST(DisparityPaths, RowRangesEqualMinmaxElement) {
    std::vector<Image<float>> images = disparityImages();
    Image<float> negative(5, 2, -1.0f);  // not a disparity, but the function is general
    negative.at(1, 0) = -2.5f;
    negative.at(2, 1) = 3.0f;
    images.push_back(std::move(negative));
    for (const Image<float>& img : images) {
        warp::ReferenceView v;
        v.disparity = img;
        warp::computeRowDisparityRange(&v);
        EXPECT_EQ(v.rowMinDisparity, rowBound(img, false));
        EXPECT_EQ(v.rowMaxDisparity, rowBound(img, true));
    }
}

// q16-packed payloads whose escapes do not match their symbols, or whose frame has no room for
// them: one error naming the problem from every decoder path, never a read past the escapes.
TEST(DisparityPaths, PackedPayloadsWithWrongEscapesAreRefused) {
    ActiveIsaGuard restore;
    const int w = 70, h = 5;
    std::vector<uint8_t> planes(2 * size_t(w) * h, 0);
    for (size_t i = 0; i < planes.size() / 2; i += 9) planes[i] = uint8_t(3 + i % 200);  // escapes
    std::vector<uint8_t> good;
    ASSERT_TRUE(reference::packQ16Planes(planes, w, h, 1, &good).isOk());
    const Result<uint64_t> size = zstdFrameContentSize(good, "test");
    ASSERT_TRUE(size.isOk());
    std::vector<uint8_t> content(static_cast<size_t>(*size));
    ASSERT_TRUE(zstdDecompressExact(good, content, "test").isOk());
    ASSERT_EQ(content.size(), packedSymbolBytes(w, h) + 2 * 39);  // pixels 0, 9, ..., 342
    auto frameOf = [](std::vector<uint8_t> bytes) {
        std::vector<uint8_t> frame;
        EXPECT_TRUE(zstdCompress(bytes, 1, &frame).isOk());
        return frame;
    };
    struct Case {
        std::vector<uint8_t> bytes;
        const char* error;
    };
    std::vector<Case> cases;
    cases.push_back({frameOf({content.begin(), content.end() - 2}), "fewer than its symbols"});
    std::vector<uint8_t> extra = content;
    extra.insert(extra.end(), {7, 0});
    cases.push_back({frameOf(extra), "1 left over"});
    cases.push_back({frameOf({content.begin(), content.end() - 1}), "whole escapes"});
    cases.push_back({frameOf({content.begin(), content.begin() + 10}), "not 90 symbol bytes"});
    cases.push_back({std::vector<uint8_t>(content.begin(), content.end()), "not a zstd frame"});
    const std::vector<float> lo(h, 0.25f), hi(h, 1.5f);
    const DisparityRange range{0.125f, 2.0f};
    for (Isa isa : runnableIsas()) {
        ASSERT_TRUE(setActiveIsa(isa).isOk());
        Image<float> out(w, h);
        ASSERT_TRUE(
            decodeDisparityQ16(good, DisparityCodec::kQuantized16Packed, range, lo, hi, &out)
                .isOk());
        for (const Case& c : cases) {
            SCOPED_TRACE(std::string(isaName(isa)) + " " + c.error);
            for (auto decode : {&decodeDisparityQ16, &reference::decodeDisparityQ16}) {
                const Status s =
                    decode(c.bytes, DisparityCodec::kQuantized16Packed, range, lo, hi, &out);
                ASSERT_FALSE(s.isOk());
                EXPECT_NE(s.message().find(c.error), std::string::npos) << s.message();
            }
        }
    }
}

}  // namespace
}  // namespace plx::remote
