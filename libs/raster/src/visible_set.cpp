// The last loop of Fig. 6 (Heo, Jung, Wohn): "for each pixel: set the visible-flag of pid TRUE",
// made O(pixels + visible) per frame by clearing only the flags the previous frame set. The row
// scan that finds each run's first pixel is a per-ISA kernel (visible_set.inl).

#include <algorithm>
#include <atomic>
#include <bit>
#include <limits>
#include <utility>

#include <plx/core/cpu.h>
#include <plx/raster/visible_set.h>

namespace plx::raster {

namespace detail {
PLX_ISA_DECLARE(size_t findRunStarts(const uint32_t* origin, ptrdiff_t stride, size_t width,
                                     int rows, int* row, uint32_t* starts, size_t capacity))
namespace {
auto activeFindRunStarts() { return PLX_ISA_PICK(findRunStarts); }
}  // namespace
}  // namespace detail

namespace {

// The run starts of the rectangle [x0, x1] x [y0, y1] of `ids` (visible_set.inl), passed to
// mark(); `starts` is scratch, kept between calls.
template <class Pixel, class Mark>
void forEachRunStart(const ImageView<Pixel>& ids, int x0, int y0, int x1, int y1,
                     std::vector<uint32_t>* starts, const Mark& mark) {
    // Room for several rows per kernel call; at least one.
    constexpr size_t kMinScratch = 4096;
    const auto findRunStarts = detail::activeFindRunStarts();
    const size_t width = size_t(x1 - x0 + 1);
    if (starts->size() < std::max(width, kMinScratch))
        starts->resize(std::max(width, kMinScratch));
    for (int row = 0; row <= y1 - y0;) {
        const size_t count = findRunStarts(ids.row(y0) + x0, ids.strideElems, width, y1 - y0 + 1,
                                           &row, starts->data(), starts->size());
        for (size_t i = 0; i < count; ++i) mark((*starts)[i]);
    }
}

// Sorts `keys`, all below `bound`, ascending: least significant digit first, in as few passes
// of at most 11 bits as cover the bound (two of 10 bits for a million triangles): about 4x
// faster than std::sort on the P-buffer's collect step (BM_SecondEyeParts). Short lists, for
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
    // IDs are triangle index + 1 in 32 bits; a larger count would wrap the flag words.
    PLX_CHECK(triangleCount < std::numeric_limits<uint32_t>::max());
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
    if (ids.empty()) return;
    forEachRunStart(ids.view(), 0, 0, ids.width() - 1, ids.height() - 1, &mRunStarts,
                    [&](uint32_t tri) { insert(tri); });
}

void VisibleSetCollector::visitTile(const ImageView<uint32_t>& ids, int x0, int y0, int x1,
                                    int y1, int slot) {
    PLX_CHECK(slot >= 0 && size_t(slot) < mSlots.size());
    SlotList& list = mSlots[size_t(slot)];
    std::vector<uint32_t>& found = list.triangles;
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
    forEachRunStart(ids, x0, y0, x1, y1, &list.runStarts, mark);
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

}  // namespace plx::raster
