// The last loop of Fig. 6 (Heo, Jung, Wohn): "for each pixel: set the visible-flag of pid TRUE",
// made O(pixels + visible) per frame with epoch stamps instead of clearing every polygon's flag.

#include <algorithm>
#include <atomic>

#if defined(__AVX2__) && !defined(PLX_NO_SIMD)
#include <immintrin.h>
#endif

#include <plx/stereo/stereo.h>

namespace plx::stereo {

namespace {

// Calls mark(id - 1) for every pixel of p[0..n) that starts a run of a non-zero ID, `last`
// being the ID before p[0]. Runs of one ID are common, so they are skipped without touching
// the stamps: eight pixels at a time with AVX2, a group that only continues the current run
// (or holds the background) costing one comparison.
template <class Mark>
void markRunStarts(const uint32_t* p, size_t n, uint32_t* last, const Mark& mark) {
    uint32_t current = *last;
    auto visit = [&](uint32_t id) {
        if (id == current || id == 0) return;
        current = id;
        mark(id - 1);
    };
    size_t i = 0;
#if defined(__AVX2__) && !defined(PLX_NO_SIMD)
    for (; i + 8 <= n; i += 8) {
        __m256i v = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + i));
        __m256i same = _mm256_or_si256(_mm256_cmpeq_epi32(v, _mm256_set1_epi32(int32_t(current))),
                                       _mm256_cmpeq_epi32(v, _mm256_setzero_si256()));
        if (_mm256_movemask_epi8(same) == -1) continue;
        for (size_t k = i; k < i + 8; ++k) visit(p[k]);
    }
#endif
    for (; i < n; ++i) visit(p[i]);
    *last = current;
}

}  // namespace

void VisibleSetCollector::begin(size_t triangleCount, int slots) {
    PLX_CHECK(slots >= 1);
    if (mStamp.size() != triangleCount) {
        mStamp.assign(triangleCount, 0);
        mEpoch = 0;
    }
    if (++mEpoch == 0) {  // wrapped after 2^32 frames: restart the stamps once
        std::fill(mStamp.begin(), mStamp.end(), 0);
        mEpoch = 1;
    }
    mList.clear();
    if (mSlots.size() < size_t(slots)) mSlots.resize(size_t(slots));
    for (SlotList& slot : mSlots) slot.triangles.clear();
    mSorted = true;
}

void VisibleSetCollector::add(const Image<uint32_t>& ids) {
    uint32_t last = 0;
    markRunStarts(ids.data(), ids.pixelCount(), &last, [&](uint32_t tri) {
        PLX_DCHECK(tri < mStamp.size());
        if (mStamp[tri] != mEpoch) {
            mStamp[tri] = mEpoch;
            mList.push_back(tri);
            mSorted = false;
        }
    });
}

void VisibleSetCollector::visitTile(const ImageView<uint32_t>& ids, int x0, int y0, int x1,
                                    int y1, int slot) {
    PLX_CHECK(slot >= 0 && size_t(slot) < mSlots.size());
    std::vector<uint32_t>& found = mSlots[size_t(slot)].triangles;
    // Another thread may meet the same triangle in its own tile: the exchange lets exactly one
    // of them list it. Relaxed order suffices, the render's join publishes the lists.
    auto mark = [&](uint32_t tri) {
        PLX_DCHECK(tri < mStamp.size());
        std::atomic_ref<uint32_t> stamp(mStamp[tri]);
        if (stamp.load(std::memory_order_relaxed) != mEpoch &&
            stamp.exchange(mEpoch, std::memory_order_relaxed) != mEpoch)
            found.push_back(tri);
    };
    uint32_t last = 0;
    for (int y = y0; y <= y1; ++y) markRunStarts(ids.row(y) + x0, size_t(x1 - x0 + 1), &last, mark);
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

size_t VisibleSetCollector::size() const {
    size_t n = mList.size();
    for (const SlotList& slot : mSlots) n += slot.triangles.size();
    return n;
}

const std::vector<uint32_t>& VisibleSetCollector::sorted() {
    for (SlotList& slot : mSlots) {
        if (slot.triangles.empty()) continue;
        mList.insert(mList.end(), slot.triangles.begin(), slot.triangles.end());
        slot.triangles.clear();
        mSorted = false;
    }
    if (!mSorted) {
        std::sort(mList.begin(), mList.end());
        mSorted = true;
    }
    return mList;
}

}  // namespace plx::stereo
