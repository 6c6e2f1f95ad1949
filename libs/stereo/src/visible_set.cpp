// The last loop of Fig. 6 (Heo, Jung, Wohn): "for each pixel: set the visible-flag of pid TRUE",
// made O(pixels + visible) per frame by clearing only the flags the previous frame set.

#include <algorithm>
#include <atomic>
#include <bit>
#include <utility>

#if defined(__AVX2__) && !defined(PLX_NO_SIMD)
#include <immintrin.h>
#endif

#include <plx/stereo/stereo.h>

namespace plx::stereo {

namespace {

// Calls mark(id - 1) for every pixel of one ID-target row p[0..n) whose non-zero ID differs from
// both the pixel before it and the pixel above it (above[0..n), the row before; null for none).
// A polygon's pixels form runs, and a run mostly continues one in the row above: of the 18.3k
// run starts of office:280's 640x480 first eye, 6.0k also differ from the pixel above
// (BM_CollectPass: 15% less CPU time). No ID is missed: in scan order, the first pixel of an ID
// has neither neighbour of that ID. An ID may still be passed to mark() more than once; mark()
// keeps the set free of repeats.
// With AVX2 eight pixels are compared with their neighbours at once, and only the lanes that
// remain are visited. Most groups of eight repeat the row above outright, and are passed over
// after that one comparison: 3.8 -> 2.3 instructions per pixel (callgrind, office:280's first
// eye), BM_CollectPass 130-175 -> 84-90 us. Inside the render, where the scan takes about
// 0.25-0.3 ms of CPU a frame, its time did not measurably change (alternated runs).
template <class Mark>
void markRunStarts(const uint32_t* p, const uint32_t* above, size_t n, const Mark& mark) {
    size_t i = 0;
#if defined(__AVX2__) && !defined(PLX_NO_SIMD)
    const __m256i shiftRight = _mm256_setr_epi32(0, 0, 1, 2, 3, 4, 5, 6);
    const __m256i zero = _mm256_setzero_si256();
    // Marks the lanes of v (pixels g .. g+7) that are neither in `same` nor 0 nor equal to their
    // left neighbour (pixel g + k - 1; none left of the row's first pixel).
    auto markGroup = [&](size_t g, __m256i v, __m256i same) {
        __m256i left =
            g ? _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + g - 1))
              : _mm256_blend_epi32(_mm256_permutevar8x32_epi32(v, shiftRight), zero, 0x01);
        same = _mm256_or_si256(
            same, _mm256_or_si256(_mm256_cmpeq_epi32(v, left), _mm256_cmpeq_epi32(v, zero)));
        for (unsigned starts = ~unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(same))) & 0xFFu;
             starts; starts &= starts - 1)
            mark(p[g + size_t(__builtin_ctz(starts))] - 1);
    };
    if (above) {
        for (; i + 8 <= n; i += 8) {
            __m256i v = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + i));
            __m256i up = _mm256_cmpeq_epi32(
                v, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(above + i)));
            if (_mm256_movemask_ps(_mm256_castsi256_ps(up)) != 0xFF) markGroup(i, v, up);
        }
    } else {
        for (; i + 8 <= n; i += 8)
            markGroup(i, _mm256_loadu_si256(reinterpret_cast<const __m256i*>(p + i)), zero);
    }
#endif
    uint32_t previous = i ? p[i - 1] : 0;
    for (; i < n; ++i) {
        if (p[i] != previous && p[i] != 0 && !(above && p[i] == above[i])) mark(p[i] - 1);
        previous = p[i];
    }
}

// Sorts `keys`, all below `bound`, ascending: least significant digit first, in as few passes
// of at most 11 bits as cover the bound (two of 10 bits for office:280's 1,016,960
// triangles). The P-buffer's collect step (gathering the threads' finds and sorting them, 1,123
// IDs) took 0.041 ms with std::sort and takes 0.011 ms so (BM_SecondEyeParts). Short lists, for
// which the digit counts would cost more than the comparisons, use std::sort.
void radixSort(std::vector<uint32_t>* keys, std::vector<uint32_t>* scratch,
               std::vector<uint32_t>* counts, size_t bound) {
    constexpr size_t kMinRadixKeys = 256;
    constexpr int kMaxDigitBits = 11;
    if (keys->size() < kMinRadixKeys) {
        std::sort(keys->begin(), keys->end());
        return;
    }
    const int keyBits = std::max(1, int(std::bit_width(std::max<size_t>(bound, 2) - 1)));
    const int passes = (keyBits + kMaxDigitBits - 1) / kMaxDigitBits;
    const int digitBits = (keyBits + passes - 1) / passes;
    const uint32_t digitMask = (1u << digitBits) - 1;
    scratch->resize(keys->size());
    for (int pass = 0; pass < passes; ++pass) {
        const int shift = pass * digitBits;
        counts->assign(size_t(1) << digitBits, 0);
        for (uint32_t k : *keys) ++(*counts)[(k >> shift) & digitMask];
        uint32_t start = 0;
        for (uint32_t& c : *counts) start += std::exchange(c, start);
        for (uint32_t k : *keys) (*scratch)[(*counts)[(k >> shift) & digitMask]++] = k;
        keys->swap(*scratch);
    }
}

}  // namespace

void VisibleSetCollector::begin(size_t triangleCount, int slots) {
    PLX_CHECK(slots >= 1);
    // Every set flag is in a list: clearing the listed ones clears them all, in O(visible).
    auto clearFlags = [this](std::vector<uint32_t>& list) {
        for (uint32_t tri : list) mFlags[tri >> 6] = 0;
        list.clear();
    };
    if (mTriangles != triangleCount) {
        mTriangles = triangleCount;
        mFlags.assign((triangleCount + 63) / 64, 0);
        mList.clear();
        for (SlotList& slot : mSlots) slot.triangles.clear();
    }
    clearFlags(mList);
    for (SlotList& slot : mSlots) clearFlags(slot.triangles);
    if (mSlots.size() < size_t(slots)) mSlots.resize(size_t(slots));
    mSorted = true;
}

void VisibleSetCollector::add(const Image<uint32_t>& ids) {
    const ImageView<const uint32_t> view = ids.view();
    for (int y = 0; y < ids.height(); ++y)
        markRunStarts(view.row(y), y > 0 ? view.row(y - 1) : nullptr, size_t(ids.width()),
                      [&](uint32_t tri) { insert(tri); });
}

void VisibleSetCollector::visitTile(const ImageView<uint32_t>& ids, int x0, int y0, int x1,
                                    int y1, int slot) {
    PLX_CHECK(slot >= 0 && size_t(slot) < mSlots.size());
    std::vector<uint32_t>& found = mSlots[size_t(slot)].triangles;
    // Another thread may meet the same triangle in its own tile: the atomic OR lets exactly one
    // of them list it. Relaxed order suffices, the render's join publishes the lists.
    auto mark = [&](uint32_t tri) {
        PLX_DCHECK(tri < mTriangles);
        const uint64_t bit = uint64_t(1) << (tri & 63);
        std::atomic_ref<uint64_t> word(mFlags[tri >> 6]);
        if (!(word.load(std::memory_order_relaxed) & bit) &&
            !(word.fetch_or(bit, std::memory_order_relaxed) & bit))
            found.push_back(tri);
    };
    for (int y = y0; y <= y1; ++y)
        markRunStarts(ids.row(y) + x0, y > y0 ? ids.row(y - 1) + x0 : nullptr,
                      size_t(x1 - x0 + 1), mark);
}

void VisibleSetCollector::addMasked(const Image<uint32_t>& ids, const Image<uint8_t>& mask) {
    PLX_CHECK(ids.width() == mask.width() && ids.height() == mask.height());
    for (size_t i = 0; i < ids.pixelCount(); ++i) {
        uint32_t id = ids.data()[i];
        if (!mask.data()[i] || id == 0) continue;
        insert(id - 1);
    }
}

void VisibleSetCollector::addTriangles(std::span<const uint32_t> triangles) {
    for (uint32_t tri : triangles) {
        PLX_CHECK(tri < mTriangles);
        insert(tri);
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
        radixSort(&mList, &mSortScratch, &mDigitCounts, mTriangles);
        mSorted = true;
    }
    return mList;
}

}  // namespace plx::stereo
