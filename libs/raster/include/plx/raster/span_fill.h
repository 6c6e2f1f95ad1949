#pragma once
// Scan conversion of one triangle restricted to given pixel spans: Fu, Bao, Peng's "modified
// scan-line conversion" (section 3), which draws a polygon found behind a hole only where the
// hole's segments are. The triangle is transformed, clipped and set up exactly as the scalar
// reference renderer does (reference.cpp shares that code), and each pixel of a span is given the
// reference's coverage test, interpolation, strict depth test and writes, so the targets at span
// pixels equal those of a full render (which equals the reference) of the same triangles.

#include <cstdint>
#include <span>

#include <plx/core/core.h>
#include <plx/raster/raster.h>
#include <plx/scene/scene.h>

namespace plx::raster {

// One run of pixels on a row: columns x0..x1 inclusive of row y. Empty when x1 < x0.
struct PixelSpan {
    int32_t y = 0;
    int32_t x0 = 0;
    int32_t x1 = -1;
};

// Draws scene-global triangle `globalTriangle` into the pixels of `spans` (clipped to the image
// and to the triangle's box): where it covers a pixel's sample and its 1/w is larger than the
// depth there, it writes colour (when the colour view is set), depth and ID. Returns the pixels
// written. Only the spans on the rows the triangle reaches are visited (binary search), so the
// cost follows the triangle's rows, not the list. A pixel listed twice is tested twice.
// Preconditions: spans in ascending row order (columns within a row in any order);
// globalTriangle < scene.triangleCount(); targets of the camera's size with depth and ID views;
// options.colorOnly false. options.clearTargets is ignored: nothing is cleared.
int64_t drawTriangleInSpans(const scene::Scene& scene, uint32_t globalTriangle,
                            const Camera& camera, const RenderOptions& options,
                            const RenderTargets& targets, std::span<const PixelSpan> spans);

// The same for a caller that holds the triangle's world-space corners, equal to the mesh's (a
// search structure's copy, in the mesh's corner order): the mesh's indices and positions are not
// read unless a piece of the triangle may cover a sample of the spans. `setUp`, when given, is
// set to whether one did (and was set up for scan conversion), whether or not it won a depth test.
int64_t drawTriangleInSpans(const scene::Scene& scene, uint32_t globalTriangle,
                            std::span<const Vec3, 3> corners, const Camera& camera,
                            const RenderOptions& options, const RenderTargets& targets,
                            std::span<const PixelSpan> spans, bool* setUp = nullptr);

}  // namespace plx::raster
