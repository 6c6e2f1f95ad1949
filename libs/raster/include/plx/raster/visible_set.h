#pragma once
// The P-buffer's visible set (Heo, Jung, Wohn, Fig. 6, last loop: "for each pixel: set the
// visible-flag of pid TRUE"): the distinct polygon IDs of an ID target, as sorted triangle
// indices. The stereo module draws its P-buffer second eye from it; any consumer of a first
// view's visibility (reprojection, remote rendering, streaming) can do the same.

#include <span>
#include <vector>

#include <plx/raster/raster.h>

namespace plx::raster {

// Collects the distinct polygon IDs of a P-buffer as sorted triangle indices, in
// O(pixels + visible) per frame: each triangle has a visible flag, one bit of a bit set, and a
// new frame clears only the flags of the previous frame's list instead of every polygon's (so
// the scene size never enters the cost after the one-time allocation). As a TileIdVisitor it
// collects during the render, tile by tile on the renderer's threads
// (RenderTargets::visibility.tileIds). The row scan is a per-ISA kernel (visible_set.inl).
class VisibleSetCollector : public TileIdVisitor {
public:
    // Starts a new set for a scene of triangleCount triangles; up to `slots` threads may call
    // visitTile concurrently. Preconditions (checked, abort): triangleCount below 2^32 - 1
    // (IDs are index + 1 in 32 bits), slots >= 1.
    void begin(size_t triangleCount, int slots = 1);
    // Adds the IDs of `ids` to the current set (IDs must be <= triangleCount).
    void add(const Image<uint32_t>& ids);
    // Adds the IDs of the pixels where mask is non-zero. Precondition (checked, abort): mask
    // has the size of `ids`.
    void addMasked(const Image<uint32_t>& ids, const Image<uint8_t>& mask);
    // Adds triangle indices (each < triangleCount).
    void addTriangles(std::span<const uint32_t> triangles);
    // Adds the IDs of one tile. Safe to call from several threads at once with distinct slots
    // below the `slots` given to begin(); not concurrently with the other add functions.
    void visitTile(const ImageView<uint32_t>& ids, int x0, int y0, int x1, int y1,
                   int slot) override;
    // The set so far, ascending (ascending order keeps the full render's draw order, so exact
    // depth ties resolve the same way when the set is drawn with Renderer::renderSubset).
    const std::vector<uint32_t>& sorted();
    size_t size() const;
    bool contains(uint32_t triangle) const {
        return triangle < mTriangles && (mFlags[triangle >> 6] >> (triangle & 63) & 1);
    }

private:
    // Lists the triangle unless this frame's set holds it already (one thread at a time).
    void insert(uint32_t tri) {
        PLX_DCHECK(tri < mTriangles);
        const uint64_t bit = uint64_t(1) << (tri & 63);
        if (!(mFlags[tri >> 6] & bit)) {
            mFlags[tri >> 6] |= bit;
            mList.push_back(tri);
            mSorted = false;
        }
    }
    // One thread's finds during visitTile, and its row scan's output, on cache lines of its own.
    struct alignas(64) SlotList {
        std::vector<uint32_t> triangles;
        std::vector<uint32_t> runStarts;
    };
    // Visible flags, 64 triangles a word. A bit set rather than a word per triangle: the
    // visible polygons of a frame cluster by mesh, so their flags share few cache lines, which
    // the render's own traffic has evicted since the last frame (128 KB for office:280's
    // 1,016,960 triangles, where epoch stamps took 4 MB).
    std::vector<uint64_t> mFlags;
    size_t mTriangles = 0;
    std::vector<uint32_t> mList;
    std::vector<uint32_t> mRunStarts;                  // add()'s row scan output
    std::vector<uint32_t> mSortScratch, mDigitCounts;  // sorted()'s radix sort
    std::vector<SlotList> mSlots;
    bool mSorted = true;
};

}  // namespace plx::raster
