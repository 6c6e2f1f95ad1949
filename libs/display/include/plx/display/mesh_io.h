#pragma once
// Interchange of warp meshes with other tools: Paul Bourke's mesh-warp text format (export and
// import), Wavefront OBJ (export) and an MPCDI-style PFM warp map (export).
//
// Display coordinates are normalised through the display rectangle (Display::displayMin/Max),
// whose framebuffer row 0 is displayMin.y. Bourke's format: line 1 the mesh type (2 =
// rectangular), line 2 "nx ny", then ny rows of nx nodes "x y u v i" with x in [-aspect, aspect]
// and y in [-1, 1] (y up), (u, v) in [0, 1] with v up, and i the intensity (a negative i marks
// a node that is not drawn).

#include <string>
#include <vector>

#include <plx/core/status.h>
#include <plx/display/quadtree.h>

namespace plx::display {

// A regular nx x ny warp grid as Bourke's format stores it, in our conventions: display
// coordinates (see optics.h) and texture coordinates with v down.
struct WarpGrid {
    int nx = 0;
    int ny = 0;
    std::vector<DVec2> displayPos;  // nx * ny, row-major from the top row
    std::vector<DVec2> uvs;
    std::vector<float> intensity;   // < 0: node not drawn
};

// Resamples a warp mesh onto the regular grid of the given level ((2^level + 1)^2 nodes) by
// linear interpolation inside its triangles, which is exactly what the second pass draws; nodes
// no triangle covers get intensity -1. Precondition: 1 <= level <= mesh.gridLevel.
WarpGrid resampleToGrid(const WarpMesh& mesh, int level);

// Bourke text (see above).
std::string formatBourke(const Display& display, const WarpGrid& grid);
// Parses a Bourke mesh. Errors name the line and the problem.
Result<WarpGrid> parseBourke(const Display& display, const std::string& text);
// The triangles of a grid's drawn cells (two per cell whose four nodes have intensity >= 0).
WarpMesh meshFromGrid(const WarpGrid& grid);

// Wavefront OBJ: "v x y 0" in display coordinates, "vt u v" (v up), one "f" per triangle.
std::string formatObj(const WarpMesh& mesh);

// MPCDI-style warp map: widthPx x heightPx pixels over the display rectangle, each holding the
// (u, v, 0) texture coordinates shown there (v down, as in the Conventions block) or NaN where no
// triangle covers it; PFM ("PF", little-endian, rows bottom to top). Preconditions: sizes >= 1.
std::vector<uint8_t> encodeWarpPfm(const Display& display, const WarpMesh& mesh, int widthPx,
                                   int heightPx);

}  // namespace plx::display
