// The last loop of Fig. 6 (Heo, Jung, Wohn): "for each pixel: set the visible-flag of pid TRUE",
// made O(pixels + visible) per frame with epoch stamps instead of clearing every polygon's flag.

#include <algorithm>

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
    for (size_t i = 0; i < n; ++i) {
        uint32_t id = p[i];
        if (id == last || id == 0) continue;
        last = id;
        uint32_t tri = id - 1;
        PLX_DCHECK(tri < mStamp.size());
        if (mStamp[tri] != mEpoch) {
            mStamp[tri] = mEpoch;
            mList.push_back(tri);
            mSorted = false;
        }
    }
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
