#pragma once
// Image<T>: an owning 2D array of pixels, row-major, (0,0) the top-left pixel. ImageView<T> is
// the non-owning (pointer, width, height, stride) view that hot kernels take.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include <plx/core/check.h>

namespace plx {

struct Rgba8 {
    uint8_t r = 0, g = 0, b = 0, a = 0;
    friend bool operator==(const Rgba8&, const Rgba8&) = default;
};
static_assert(sizeof(Rgba8) == 4);

// Non-owning view. strideElems is the distance between rows in elements of T.
template <class T>
struct ImageView {
    T* data = nullptr;
    int width = 0;
    int height = 0;
    ptrdiff_t strideElems = 0;

    T* row(int y) const { return data + ptrdiff_t(y) * strideElems; }
    T& at(int x, int y) const {
        PLX_DCHECK(x >= 0 && y >= 0 && x < width && y < height);
        return row(y)[x];
    }
    void fill(const T& v) const {
        for (int y = 0; y < height; ++y) {
            T* r = row(y);
            for (int x = 0; x < width; ++x) r[x] = v;
        }
    }
};

template <class T>
class Image {
public:
    Image() = default;
    Image(int width, int height, const T& init = T{}) { resize(width, height, init); }

    // Reallocates only when the size grows past the capacity already held.
    void resize(int width, int height, const T& init = T{}) {
        PLX_CHECK(width >= 0 && height >= 0);
        mWidth = width;
        mHeight = height;
        mPixels.assign(size_t(width) * size_t(height), init);
    }

    int width() const { return mWidth; }
    int height() const { return mHeight; }
    size_t pixelCount() const { return mPixels.size(); }
    bool empty() const { return mPixels.empty(); }
    T* data() { return mPixels.data(); }
    const T* data() const { return mPixels.data(); }
    T* row(int y) { return mPixels.data() + size_t(y) * size_t(mWidth); }
    const T* row(int y) const { return mPixels.data() + size_t(y) * size_t(mWidth); }
    T& at(int x, int y) {
        PLX_DCHECK(x >= 0 && y >= 0 && x < mWidth && y < mHeight);
        return mPixels[size_t(y) * size_t(mWidth) + size_t(x)];
    }
    const T& at(int x, int y) const {
        PLX_DCHECK(x >= 0 && y >= 0 && x < mWidth && y < mHeight);
        return mPixels[size_t(y) * size_t(mWidth) + size_t(x)];
    }
    void fill(const T& v) { std::fill(mPixels.begin(), mPixels.end(), v); }

    ImageView<T> view() { return {mPixels.data(), mWidth, mHeight, mWidth}; }
    ImageView<const T> view() const { return {mPixels.data(), mWidth, mHeight, mWidth}; }

    friend bool operator==(const Image& a, const Image& b) {
        return a.mWidth == b.mWidth && a.mHeight == b.mHeight && a.mPixels == b.mPixels;
    }

private:
    int mWidth = 0;
    int mHeight = 0;
    std::vector<T> mPixels;
};

// Interleaved 8-bit image with 1 to 4 channels (grey, grey+alpha, RGB, RGBA), as files hold them.
struct ByteImage {
    int width = 0;
    int height = 0;
    int channels = 0;
    std::vector<uint8_t> bytes;  // width * height * channels, row-major, no padding

    size_t rowBytes() const { return size_t(width) * size_t(channels); }
    uint8_t* pixel(int x, int y) { return bytes.data() + (size_t(y) * width + x) * channels; }
    const uint8_t* pixel(int x, int y) const {
        return bytes.data() + (size_t(y) * width + x) * channels;
    }
    friend bool operator==(const ByteImage&, const ByteImage&) = default;
};

// Expands 1-4 channels to RGBA (grey to RGB, missing alpha to 255). Preconditions (checked,
// abort): 1-4 channels, a size of at least 0x0, and bytes of exactly that size.
Image<Rgba8> toRgba8(const ByteImage& image);
// Packs RGBA into a ByteImage with the given channel count (1: luma of RGB, 2: luma+alpha).
// Precondition (checked, abort): channels 1-4.
ByteImage fromRgba8(const Image<Rgba8>& image, int channels = 4);

}  // namespace plx
