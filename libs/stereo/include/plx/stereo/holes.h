#pragma once
// Holes of a reprojected second eye: hole segments per scanline merged into holes (Fu, Bao,
// Peng, section 2, Fig. 5), classified by the ID buffer (section 3), and expansion holes filled.
//
// Segments. A segment is a maximal run of hole pixels on one row. Two segments on consecutive
// rows belong to the same hole when their column ranges overlap (4-connectivity) or overlap or
// touch diagonally (8-connectivity, the default: a diagonal chain of hole pixels is one hole, so
// the later fill sees one region and one box for it).
//
// Merging. The paper keeps an active hole list, most recently modified hole first, and searches
// it for the hole each new segment joins. A new segment may join several holes at once (the two
// arms of a U), so the search has to reach every candidate and cannot stop at the first; this
// finds them instead by sweeping the previous row's segments in column order beside the current
// row's (linear in the segments, where the list search is linear in the open holes per segment)
// and merges the holes through union-find. The holes and segments that come out are the same.

#include <cstdint>
#include <functional>
#include <vector>

#include <plx/core/image.h>
#include <plx/stereo/reproject.h>

namespace plx::stereo {

enum class HoleConnectivity { k4, k8 };

// Fu Fig. 5: one run of hole pixels.
struct HoleSegment {
    int32_t xStart = 0;  // first hole pixel's column
    int32_t xEnd = 0;    // last hole pixel's column (inclusive), >= xStart
    int32_t count = 0;   // pixels in the run, xEnd - xStart + 1
    int32_t y = 0;       // row
    int32_t next = -1;   // index in HoleSet::segments of the hole's next segment, -1 = last
};

// Inclusive pixel box.
struct PixelBox {
    int32_t x0 = 0, y0 = 0, x1 = -1, y1 = -1;
};

// The most triangles classifyHoles joins into one expansion hole.
constexpr int kMaxSurfacePolygons = 8;

// Fu section 3: expansion holes lie inside one polygon; disocclusion holes show what the first
// eye could not see.
enum class HoleClass { kUnclassified, kExpansion, kDisocclusion };

struct Hole {
    int32_t firstSegment = 0;  // index in HoleSet::segments; the hole's segments follow it
    int32_t segmentCount = 0;  // segments [firstSegment, firstSegment + segmentCount), row order
    int32_t pixelCount = 0;
    PixelBox box;  // the enclosing box of its pixels
    HoleClass holeClass = HoleClass::kUnclassified;
    uint32_t polygonId = 0;  // expansion holes: the polygon's ID (triangle + 1); else 0
    // Expansion holes: the distinct triangles bordering it, 1 as in the paper, up to
    // kMaxSurfacePolygons where classifyHoles' sameSurface joined them (polygonId the first in
    // scan order); else 0.
    int32_t polygonCount = 0;
};

// The holes of one frame. Holes are ordered by their first pixel in scan order; each hole's
// segments are contiguous in `segments`, in row order then column order, and also chained by
// `next` (so a fill may unlink segments it covers).
struct HoleSet {
    std::vector<HoleSegment> segments;
    std::vector<Hole> holes;
    int64_t pixelCount = 0;
};

// Working memory of findHoles(), kept between frames so that no call allocates after the first
// frames of a given hole count.
struct HoleScratch {
    std::vector<HoleSegment> rowSegments;  // all segments in scan order
    std::vector<int32_t> label;            // provisional hole of each segment
    std::vector<int32_t> parent;           // union-find over provisional holes
    std::vector<int32_t> finalIndex;       // provisional hole -> index in HoleSet::holes
    std::vector<int32_t> cursor;           // per final hole: next free slot in HoleSet::segments
};

// Finds the hole segments of a mask (non-zero = hole) and merges them into holes; classes are
// left kUnclassified. Preconditions: out and scratch are not shared with a concurrent call.
void findHoles(ImageView<const uint8_t> holeMask, HoleConnectivity connectivity,
               HoleScratch& scratch, HoleSet& out);
// The same from the hole runs reproject() listed (SecondEyeTargets::holeRuns) while its threads
// wrote the rows: the same holes and segments as from the mask, without another pass over it.
void findHoles(const HoleRuns& runs, HoleConnectivity connectivity, HoleScratch& scratch,
               HoleSet& out);

// Classifies each hole by the IDs of its bordering pixels along the rows, the left and right
// neighbour of each of its segments (the pixels the reprojection wrote beside it and an
// expansion fill interpolates from). All one non-zero ID: expansion hole of that polygon.
// Otherwise a disocclusion: neighbours of two polygons, or of ID 0 (no polygon to extend), or a
// segment reaching the left or right image border (what enters there, such as a pole at the
// edge of the first eye's view, was never in the first eye). Pixels above and below are not
// consulted: rows move independently, and a polygon's own top or bottom edge would otherwise
// make its cracks disocclusions.
// Beyond the paper: the paper's polygons are whole faces, where ours are triangles, so a crack
// across the diagonal of a quad, or running over a wall of many triangles, borders several IDs.
// With `sameSurface` given, a hole whose neighbours are at most kMaxSurfacePolygons triangles,
// each joined by it to one found before (in scan order), is an expansion hole of all of them
// (polygonCount): the surface the first eye saw on both sides of the crack is continuous, as
// inside one polygon.
// Holes are classified in parallel on `pool` when given (sameSurface is then called from its
// threads); the result does not depend on the thread count.
// Precondition: holes were found on a mask of id's size.
using SameSurface = std::function<bool(uint32_t idA, uint32_t idB)>;
void classifyHoles(ImageView<const uint32_t> id, HoleSet& holes,
                   const SameSurface& sameSurface = {}, ThreadPool* pool = nullptr);

// Fills every expansion hole by linear interpolation along its rows between each segment's two
// neighbours (Fu section 3): colour per channel and 1/w linear in the column, ID the hole's
// polygon (of two, the nearer neighbour's), hole mask cleared (unless empty). Disocclusion holes
// are left as they are. (Evaluating the polygon itself at the hole pixels is exact where this is
// linear in sRGB; it needs the rasterizer's subset render over the hole segments, which comes
// with the disocclusion fill.) Preconditions: holes classified by classifyHoles() on second.id;
// targets of one size.
void fillExpansionHoles(const HoleSet& holes, const SecondEyeTargets& second);

}  // namespace plx::stereo
