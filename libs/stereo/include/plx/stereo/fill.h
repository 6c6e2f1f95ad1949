#pragma once
// Filling the holes of a reprojected second eye (Fu, Bao, Peng, section 3 and the algorithm
// sketch): only the hole pixels are drawn, each from the polygons that can appear there.
//
// Expansion holes (a polygon seen more obliquely by the second eye, its pixels spread apart)
// are drawn from their one polygon (HoleSet's polygonId), or from each of the triangles of one
// surface that classifyHoles joined (trianglesOfOneSurface): drawTriangleInSpans over the hole's
// segments evaluates it exactly where the paper's linear interpolation (fillExpansionHoles,
// kept as ExpansionFill::kInterpolate) approximates it in sRGB. Evaluation is the default: with
// Gouraud shading it gives every expansion pixel the full render's colour where interpolation
// gives 90% of them, for the same fill time (docs/stereo-results.md, reprojection section). Pixels
// the polygon does not cover (the crack crossed its edge) fall through to the disocclusion search
// below. As in the paper, a pixel the polygon covers is taken as visible without asking whether
// something else is nearer there.
//
// Disocclusion holes (surfaces the first eye could not see):
//  1. the box hierarchy flags the triangles whose boxes may reach the hole's enclosing
//     rectangle (BoxHierarchy::markHole, the paper's per-node flags);
//  2. the BSP tree is walked front to back from the second eye, skipping subtrees whose box
//     cannot reach the rectangle (BspTree::forEachFrontToBackPruned);
//  3. a fragment whose source triangle is not flagged is skipped; the rest get the separating
//     test of their own corners against the rectangle, then a test of their projection against
//     the open segments' end samples;
//  4. the fragment's source triangle is scan-converted into the hole's still-open segments
//     (drawTriangleInSpans, the paper's modified scan-line conversion), with the depth test;
//  5. the pixels it covers leave the segments, and the walk stops once none are left (the
//     paper's termination: "until the hole is filled").
// Pixels still open when the walk ends show nothing: clear colour, depth 0, ID 0
// (PixelSource::kDisocclusionEmpty). Pixels that are not holes are left alone here; where
// geometry outside the first eye's view hides what landed on them, drawUnseenOccluders
// (unseen.h) draws it after the fill.
//
// Where this differs from the paper:
//  - The separating tests (steps 1-3) are plane tests against the rectangle's frustum
//    (scene::RectFrustum) rather than projected enclosing boxes: a few multiply-adds per box,
//    and they also reject what crosses the near plane beside the hole, such as the boxes of
//    the large subtrees around the eye, which a projected box must accept.
//  - The search starts at the root, pruned by subtree boxes, and "from the polygons surrounding
//    the hole to the back" becomes a bound: subtrees, boxes and fragments wholly in front of the
//    nearest pixel around a hole are skipped (both searches). It does not hold at the image
//    border: a pole entering there is in front of everything around the hole it opens, so holes
//    touching the border get the whole walk.
//  - A split triangle is drawn whole when its first fragment is reached (its pixels equal the
//    full render's there). Its later fragments may lie behind polygons still to come, so the
//    pixels it covers stay open (the depth test lets a nearer polygon replace them) until every
//    fragment of the triangle has been passed, or the walk ends.
//  - A hole whose box fits in a kFillTile square is searched whole; a larger one per screen
//    tile it touches: the pixels of one hole in one tile form a piece with its own rectangle
//    (a small hole across a tile boundary stays one piece, one walk). A tall hole (the strip a
//    converged rig opens at the image border) would otherwise have one rectangle reaching most of
//    the scene, so every polygon along the strip would be tested against and drawn over all of its
//    rows. Pieces are independent (disjoint pixels, and each pixel's result is the nearest polygon
//    there whatever the grouping); the holes run in parallel, a thread cutting one hole into its
//    pieces and filling them, each thread with its own flags.
// FillSearch::kBoxHierarchy (the default; beyond the paper) replaces steps 1-3 and 5 by one
// walk of the box hierarchy per piece, without the BSP order, over its four-wide copy
// (FillScene::wideBoxes: four boxes, or four of a leaf's triangles, tested in one SIMD step): a
// node is entered when its box reaches the piece's frustum, children nearest box first; a leaf's
// triangles get the corner and projection tests and are scan-converted into every pixel of the
// piece with the depth test, so a nearer triangle drawn later replaces a farther one and each
// pixel ends with the nearest triangle, as in the full render. Once no pixel of the piece is
// empty, a box (or triangle) whose nearest point lies behind the farthest pixel drawn is skipped
// with its subtree: the paper's termination as a depth bound. It costs one traversal of tight
// boxes instead of the flag pass plus the BSP walk over loose subtree boxes (the planes cut the
// scene anywhere), and split triangles need no bookkeeping: the fill is 2.2x (10k triangles) to
// 4.1x (1M) faster, with the same pixels (docs/stereo-results.md, reprojection section).
// A piece of at most kFillRayPixels pixels is walked along the rays through its samples instead
// of its frustum (box_search.h): a box is entered where a ray, widened by a fraction of a pixel,
// passes through it, and its depth for the bound is where the first ray enters it. A larger
// piece's boxes also meet the bundle of its rectangle's rays (bounds on their directions per
// axis), which rejects boxes the plane tests pass and bounds a box's depth inside the rectangle.
// FillSearch::kBspOrder keeps the paper's search for comparison.
// Result: a disocclusion pixel equals the full render's wherever the nearest polygon there is
// in the tree (degenerate triangles are not) and, for the BSP search, the BSP order is exact
// (bsp.h's limits). Where two triangles are exactly as near at a pixel, the one drawn first
// keeps it, in either search.

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include <plx/core/parallel.h>
#include <plx/raster/raster.h>
#include <plx/scene/box_hierarchy.h>
#include <plx/scene/bsp.h>
#include <plx/stereo/holes.h>
#include <plx/stereo/reproject.h>

namespace plx::stereo {

// Side in pixels of the screen tiles that cut holes into pieces (see above): small enough that a
// piece's rectangle stays local, large enough that most holes (cracks and slivers of a few
// pixels) are one piece. Against 64, the fill costs 3-6% more with 32 (more pieces, each with
// its own search from the root), 3% more with 128 and about as much with 96 (office:3, 28 and
// 280).
constexpr int kFillTile = 64;

// The most pixels of a piece that the box search walks along their samples' rays rather than by
// the piece's frustum (see above). On office:280, 266 of the 356 interior pieces; against
// frustums for all, the fill is 6% faster (box lanes -24%, triangles tested -38%), where up to 1,
// 4, 8, 32 and 64 pixels give 2-3%, 5%, 6%, 6% and 6-8%: the ray tests grow with the pixels.
constexpr int kFillRayPixels = 16;

// How the disocclusion search orders the polygons it draws (see the top of this header).
enum class FillSearch {
    kBoxHierarchy,  // box hierarchy, nearest box first, the depth test deciding (default)
    kBspOrder,      // the paper's front-to-back BSP walk, each pixel final when first drawn
};

// The box hierarchy collapsed four-wide for FillSearch::kBoxHierarchy: a node stands for an inner
// node of the binary hierarchy and holds its grandchildren (a child that is a leaf takes one lane
// itself), their boxes lane by lane, so that one SIMD step tests all four against a hole.
struct WideBoxNode {
    std::array<float, 4> loX{}, loY{}, loZ{}, hiX{}, hiY{}, hiZ{};
    // Inner lane: index of its WideBoxNode; leaf lane: its first entry of boxes.triangles().
    std::array<uint32_t, 4> first{};
    std::array<uint16_t, 4> count{};  // leaf lane: its triangles (>= 1); inner lane: 0
    uint8_t lanes = 0;                // lanes 0 .. lanes - 1 are in use
    Aabb box(size_t lane) const {
        return {{loX[lane], loY[lane], loZ[lane]}, {hiX[lane], hiY[lane], hiZ[lane]}};
    }
};

// Triangle corners by entry of BoxHierarchy::triangles(): corner k of entry i is
// (x[k][i], y[k][i], z[k][i]). Each array holds kPadding entries more, copies of the last, so that
// four entries can be loaded from any entry on.
struct LeafCorners {
    static constexpr size_t kPadding = 3;
    std::array<std::vector<float>, 3> x, y, z;
    std::array<Vec3, 3> triangle(size_t entry) const {
        return {Vec3(x[0][entry], y[0][entry], z[0][entry]),
                Vec3(x[1][entry], y[1][entry], z[1][entry]),
                Vec3(x[2][entry], y[2][entry], z[2][entry])};
    }
};

// What the fill reuses for every view of one scene.
struct FillScene {
    // The BSP tree and fragmentsOfTriangle, which FillSearch::kBspOrder alone walks, are built
    // only for it (buildFillScene); bspBuilt says whether they were.
    bool bspBuilt = false;
    scene::BspTree bsp;
    scene::BoxHierarchy boxes;
    // BSP fragments of each scene-global triangle (0: degenerate, not in the tree), at most
    // 65535: the tree's fragment bound (BspConfig::maxFragmentsPerTriangle) keeps real counts far
    // below it, and a saturated count only keeps a triangle's pixels open longer.
    std::vector<uint16_t> fragmentsOfTriangle;
    // Corners of the box hierarchy's triangles in its leaf order, coordinate by coordinate:
    // FillSearch::kBoxHierarchy tests four triangles of a leaf at a time.
    LeafCorners boxCorners;
    // boxes collapsed four-wide (root first; empty when boxes is).
    std::vector<WideBoxNode> wideBoxes;

    // Whether fillHoles can run `search` on it.
    bool serves(FillSearch search) const { return search != FillSearch::kBspOrder || bspBuilt; }
};

// Builds what `search` walks for `scene`: the box hierarchy, which both searches use, and for
// FillSearch::kBspOrder the BSP tree too. The default search leaves the tree out: on office:290
// it takes three times as long to build as the hierarchy, and a model whose triangles cut each
// other too often can exceed its fragment bound. With a pool the hierarchy's subtrees are built
// in parallel (BoxHierarchy::build). Preconditions: `scene` is finalized. Errors: those of
// BoxHierarchy::build, and for kBspOrder those of BspTree::build.
Result<FillScene> buildFillScene(const scene::Scene& scene,
                                 FillSearch search = FillSearch::kBoxHierarchy,
                                 const scene::BspConfig& bsp = {},
                                 const scene::BoxHierarchyConfig& boxes = {},
                                 ThreadPool* pool = nullptr);

// Whether triangles a and b (scene-global indices) are parts of one surface: they share an edge
// (two corners of one at the positions of two corners of the other), or they lie in one plane
// (every corner of b within kOneSurfacePlaneTolerance of the larger triangle side from a's
// plane: the split quads, T-junctions and tiled walls of real meshes). classifyHoles takes a
// crack between two such triangles, which the first eye saw side by side, for an expansion hole
// of both (holes.h).
constexpr float kOneSurfacePlaneTolerance = 1e-4f;
bool trianglesOfOneSurface(const scene::Scene& scene, uint32_t a, uint32_t b);

enum class ExpansionFill {
    kEvaluate,     // draw the hole's polygon over its segments (default)
    kInterpolate,  // fillExpansionHoles: linear along each segment between its neighbours
};

struct FillOptions {
    ExpansionFill expansion = ExpansionFill::kEvaluate;
    FillSearch search = FillSearch::kBoxHierarchy;
    // Beyond the paper, off by default: before the search, a disocclusion hole's pixels are drawn
    // from the polygons around it (the distinct IDs beside its segments, up to
    // kMaxSurfacePolygons), each pixel final when first covered, as the paper takes an expansion
    // hole's polygon; the search runs only for the pixels they leave open. Most holes are
    // slivers beside a foreground edge that the surface behind it fills, so the search runs for
    // far fewer pieces (box nodes 53k -> 16k on office:280 at 1280x720); a pixel where something
    // the first eye did not see lies between that surface and the eye keeps the surface
    // (identical pixels 99.39% -> 99.32%, 40.4 -> 39.3 dB; docs/stereo-results.md).
    bool surroundingFirst = false;
    // The first eye's render options (shading, lighting, culling, clear colour): holes are drawn
    // with them. clearTargets and colorOnly are ignored.
    raster::RenderOptions render;
};

struct FillStats {
    int64_t expansionPixels = 0;     // pixels drawn (or interpolated) from an expansion polygon
    int64_t disocclusionPixels = 0;  // pixels drawn by the disocclusion search
    int64_t emptyPixels = 0;         // hole pixels no polygon covers
    size_t nodesVisited = 0;         // BSP nodes the searches reached
    size_t boxNodesTested = 0;       // box-hierarchy nodes tested (markHole, or the box search)
    size_t polygonsTested = 0;       // fragments given the separating test
    size_t polygonsDrawn = 0;        // triangles set up for scan conversion into a hole
    size_t rayPieces = 0;            // pieces the box search walked along their samples' rays
};

// Working memory of fillHoles, one slot per thread, kept between frames.
class FillScratch {
public:
    FillScratch();
    ~FillScratch();
    struct Slot;

private:
    friend FillStats fillHoles(const scene::Scene&, const FillScene&, const Camera&,
                               const FillOptions&, const HoleSet&, const SecondEyeTargets&,
                               ImageView<uint8_t>, FillScratch*, ThreadPool*);
    std::vector<std::unique_ptr<Slot>> mSlots;
};

// Fills every hole of `holes` in the second eye's targets and writes the PixelSource of each
// hole pixel to holeClass, whatever it held there (other pixels are left as they are, so
// holeClass may be the hole mask reproject() wrote: 0, kReprojected, where a pixel landed); a
// holeClass with no data is not written, and the stats are the same. Runs the holes on `pool`
// when given; the result does not depend on the thread count. Preconditions: options.search and
// options.expansion among their enumerators (checked, abort); `fill` was built from `scene` for
// options.search (FillScene::serves); camera is the second eye's; holes were found in what
// reproject() wrote to `second` (its hole mask or hole runs) and classified on second.id
// (classifyHoles); hole pixels hold depth 0 and ID 0 (as reproject() leaves them); targets, and
// holeClass if it has data, of the camera's size.
FillStats fillHoles(const scene::Scene& scene, const FillScene& fill, const Camera& camera,
                    const FillOptions& options, const HoleSet& holes,
                    const SecondEyeTargets& second, ImageView<uint8_t> holeClass,
                    FillScratch* scratch, ThreadPool* pool = nullptr);

}  // namespace plx::stereo
