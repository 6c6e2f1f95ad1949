// The last loop of Fig. 6 (Heo, Jung, Wohn): "for each pixel: set the visible-flag of pid TRUE",
// made O(pixels + visible) per frame with epoch stamps instead of clearing every polygon's flag.

#include <algorithm>

#if defined(__AVX2__) && !defined(PLX_NO_SIMD)
#include <immintrin.h>
#endif

#include <plx/stereo/stereo.h>

namespace plx::stereo {

void VisibleSetCollector::begin(size_t triangleCount) {
    if (mStamp.size() != triangleCount) {
        mStamp.assign(triangleCount, 0);
        mEpoch = 0;
    }
    if (++mEpoch == 0) {  // wrapped after 2^32 frames: restart the stamps once
        std::fill(mStamp.begin(), mStamp.end(), 0);
        mEpoch = 1;
    }
    mList.clear();
    mSorted = true;
}

void VisibleSetCollector::add(const Image<uint32_t>& ids) {
    const uint32_t* p = ids.data();
    const size_t n = ids.pixelCount();
    uint32_t last = 0;  // runs of one ID are common: skip them without touching the stamps
    auto visit = [&](uint32_t id) {
        if (id == last || id == 0) return;
        last = id;
        uint32_t tri = id - 1;
        PLX_DCHECK(tri < mStamp.size());
        if (mStamp[tri] != mEpoch) {
            mStamp[tri] = mEpoch;
            mList.push_back(tri);
            mSorted = false;
        }
    };
    size_t i = 0;
#if defined(__AVX2__) && !defined(PLX_NO_SIMD)
    // Eight pixels at a time: a group that only continues the current run (or holds the
    // background) is skipped with one comparison; the others go through visit() in order.
    for (; i + 8 <= n; i += 8) {
        __m256i v = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + i));
        __m256i same = _mm256_or_si256(_mm256_cmpeq_epi32(v, _mm256_set1_epi32(int32_t(last))),
                                       _mm256_cmpeq_epi32(v, _mm256_setzero_si256()));
        if (_mm256_movemask_epi8(same) == -1) continue;
        for (size_t k = i; k < i + 8; ++k) visit(p[k]);
    }
#endif
    for (; i < n; ++i) visit(p[i]);
}

void VisibleSetCollector::addMasked(const Image<uint32_t>& ids, const Image<uint8_t>& mask) {
    PLX_CHECK(ids.width() == mask.width() && ids.height() == mask.height());
    for (size_t i = 0; i < ids.pixelCount(); ++i) {
        uint32_t id = ids.data()[i];
        if (!mask.data()[i] || id == 0) continue;
        uint32_t tri = id - 1;
        if (mStamp[tri] != mEpoch) {
            mStamp[tri] = mEpoch;
            mList.push_back(tri);
            mSorted = false;
        }
    }
}

void VisibleSetCollector::addTriangles(std::span<const uint32_t> triangles) {
    for (uint32_t tri : triangles) {
        PLX_CHECK(tri < mStamp.size());
        if (mStamp[tri] != mEpoch) {
            mStamp[tri] = mEpoch;
            mList.push_back(tri);
            mSorted = false;
        }
    }
}

const std::vector<uint32_t>& VisibleSetCollector::sorted() {
    if (!mSorted) {
        std::sort(mList.begin(), mList.end());
        mSorted = true;
    }
    return mList;
}

}  // namespace plx::stereo
