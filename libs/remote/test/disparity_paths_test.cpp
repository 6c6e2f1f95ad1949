// White-box: the q16 disparity codec's per-ISA kernels (disparity_kernels.inl) against its
// pixel-by-pixel reference (disparity_q16_reference.cpp), byte for byte and float for float, on
// every path this process can run; and the row ranges the warp computes against
// std::minmax_element.
#include <algorithm>
#include <cstring>
#include <random>

#include <gtest/gtest.h>

#include <plx/core/cpu.h>
#include <plx/warp/reference.h>

#include "payloads.h"
#include "test_sets.h"

namespace plx::remote {
namespace {

struct RestoreIsa {
    Isa saved = activeIsa();
    ~RestoreIsa() { EXPECT_TRUE(setActiveIsa(saved).isOk()); }
};

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

TEST(DisparityPaths, EveryKernelEqualsTheReference) {
    RestoreIsa restore;
    const std::vector<Image<float>> images = disparityImages();
    for (Isa isa : runnableIsas()) {
        ASSERT_TRUE(setActiveIsa(isa).isOk());
        for (size_t i = 0; i < images.size(); ++i) {
            SCOPED_TRACE(std::string(isaName(isa)) + " image " + std::to_string(i));
            const Image<float>& img = images[i];
            const DisparityRange range = disparityRange(img);
            const DisparityRange expected = reference::disparityRange(img);
            ASSERT_EQ(range.dmin, expected.dmin);
            ASSERT_EQ(range.dmax, expected.dmax);
            for (DisparityCodec codec :
                 {DisparityCodec::kQuantized16, DisparityCodec::kQuantized16Deflate}) {
                std::vector<uint8_t> bytes, referenceBytes;
                ASSERT_TRUE(encodeDisparityQ16(img, range, codec, 3, &bytes).isOk());
                ASSERT_TRUE(
                    reference::encodeDisparityQ16(img, range, codec, 3, &referenceBytes).isOk());
                ASSERT_EQ(bytes, referenceBytes);
                const std::vector<float> lo = rowBound(img, false), hi = rowBound(img, true);
                Image<float> out(img.width(), img.height()),
                    referenceOut(img.width(), img.height());
                ASSERT_TRUE(decodeDisparityQ16(bytes, codec, range, lo, hi, &out).isOk());
                ASSERT_TRUE(
                    reference::decodeDisparityQ16(bytes, codec, range, lo, hi, &referenceOut)
                        .isOk());
                ASSERT_EQ(std::memcmp(out.data(), referenceOut.data(), out.pixelCount() * 4), 0);
            }
        }
    }
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

}  // namespace
}  // namespace plx::remote
