#pragma once
// Beyond the paper: geometry outside the first eye's view that stands in front of pixels the
// reprojection moved into the second eye.
//
// Reprojection (reproject.h) and the hole fill (fill.h) take a pixel that some first-eye pixel
// landed on as settled. Near the image border on the side the second eye is offset to (the right
// border when the left eye is first), that fails: a second-eye ray there passes, in front of the
// surface that landed on its pixel, through space the first eye's frustum does not reach, and a
// pole standing in that space hides the surface in the full render while no first-eye pixel of
// it exists to land. Only the pole's part in the border strip the rig opens is a hole; beside it
// the background stays in its place (docs/stereo-results.md, "Geometry outside the first view").
//
// Why the fix is exact. On a second-eye sample at column X + 0.5 a point of 1/w v comes from
// first-eye position x1 = X + 0.5 - (a v + b) (DisparityLine), monotonic in v. A first-eye pixel
// that lands on X sampled x1 in [0.5, width - 0.5]; with a < 0 (left eye first) any point of the
// ray with x1 >= width is nearer than every such landing, with a > 0 any point with x1 <= 0 is.
// Those points form the unseen wedge: the second eye's frustum beyond the first eye's side
// plane. So where the nearest geometry on a ray lies in the wedge, it is what the full render
// shows, whatever landed or was filled there; where it does not, nothing in the wedge is on
// the ray and the pixel keeps its value.
//
// drawUnseenOccluders: (1) walks the box hierarchy nearest box first with the wedge's planes (the
// second eye's frustum, the first eye's side plane flipped, and a far plane where the rig's
// offset leaves the wedge no sample beyond it) and clips each triangle of the leaves it reaches
// to them; (2) takes the pixel rectangle of a clipped part's projection, within the columns a
// wedge sample can fall on; (3) scan-converts the triangle over it with the depth test into
// scratch targets (drawTriangleInSpans), unless they already hold something nearer than its
// nearest point throughout, and does not open a box whose own rectangle they so hide; (4) where
// the nearest sample lies in the wedge (the test above on its 1/w), copies it into the second
// eye. With the converged rig the wedge closes at the convergence distance and holds a few
// triangles or none; the parallel rig's runs as deep as the offset allows a sample in it (clip
// w up to 2 |a|), and the walk ends at the walls that hide the rest.

#include <cstdint>
#include <utility>
#include <vector>

#include <plx/raster/raster.h>
#include <plx/raster/span_fill.h>
#include <plx/stereo/fill.h>
#include <plx/stereo/reproject.h>

namespace plx::stereo {

struct UnseenStats {
    size_t boxNodesTested = 0;    // box hierarchy nodes tested against the wedge
    size_t trianglesReached = 0;  // triangles with a part in the wedge
    size_t trianglesDrawn = 0;    // of those, the ones not hidden there, drawn
    // Second-eye pixels whose nearest surface lies in the wedge, written from it (hole pixels
    // among them held the same surface already when the hole search is exact).
    int64_t pixels = 0;
};

// Working memory of drawUnseenOccluders, kept between frames.
struct UnseenScratch {
    // Colour, depth and ID of the band, columns x0..x1 of every row: views of the second eye's
    // size whose stride is the band's width, so that the band's rows lie packed in a few
    // cache lines (a full-size plane costs a miss a row). Only columns x0..x1 may be touched:
    // the others alias neighbouring rows (every address stays inside the plane).
    raster::RenderTargets bandTargets(int width, int height, int x0, int x1);
    std::vector<Rgba8> color;
    std::vector<float> depth;
    std::vector<uint32_t> id;
    std::vector<int32_t> rowX0, rowX1;  // per row, the band's cleared columns (x0 > x1: none)
    std::vector<raster::PixelSpan> rectSpans;
    std::vector<std::pair<float, uint32_t>> heap;  // box nodes to open, by their nearest clip w
};

// Writes into `second` (colour; depth and ID where their views have data) the nearest surface of
// every pixel where it lies in the unseen wedge of the rig whose eyes are `first` and
// `secondCamera`, and `line` the disparity from the first to the second (see above); where
// holeClass has data, marks the pixels it replaced that held a reprojected pixel
// PixelSource::kUnseen. Draws with `render` (colorOnly and clearTargets ignored). Zero
// separation (line.perInvW == 0) has no wedge: nothing is written. Preconditions: `fill` built
// from `scene` (its box hierarchy and corners); the cameras differ only by the rig (same size,
// rows, near plane); targets of that size.
UnseenStats drawUnseenOccluders(const scene::Scene& scene, const FillScene& fill,
                                const Camera& first, const Camera& secondCamera,
                                const DisparityLine& line, const raster::RenderOptions& render,
                                const raster::RenderTargets& second, ImageView<uint8_t> holeClass,
                                UnseenScratch* scratch);

}  // namespace plx::stereo
