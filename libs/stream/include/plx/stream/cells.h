#pragma once
// Cells of a streamed scene (Marvie & Bouatouch section 3): boxes of space, each polygon in
// exactly one, between which visibility is precomputed (visibility.h). docs/stream-format.md
// states the rules a client relies on.

#include <cstdint>
#include <vector>

#include <plx/core/core.h>
#include <plx/scene/scene.h>

namespace plx::stream {

// Largest number of cells a database holds (docs/stream-format.md).
constexpr int kMaxCells = 65536;

struct CellConfig {
    // kd rule for scenes without rooms: a box holding more than this many triangle centroids is
    // split. 2,048 keeps a cell's geometry file near 100 KB and an office-sized room in one or
    // two cells.
    int maxTrianglesPerCell = 2048;
    // ... unless its longest side is shorter than this fraction of the scene's diagonal (stops
    // splitting dense clusters into slivers no viewer stands in).
    float minSideFraction = 0.01f;
    // The kd build stops splitting once it has this many leaves (bounds the preprocessing).
    int maxKdCells = 4096;
};

struct Cells {
    std::vector<Aabb> boxes;               // one per cell; convex hull of the cell
    std::vector<uint32_t> cellOfTriangle;  // per global triangle index
    bool fromRooms = false;                // true: the scene's rooms; false: the kd rule
};

// The scene's rooms when it has some (Scene::rooms), else the kd subdivision of its bounds.
// Each triangle is assigned by cellOfPoint of its centroid. Errors: more than kMaxCells rooms;
// config out of range (maxTrianglesPerCell < 1, maxKdCells outside 1..kMaxCells).
Result<Cells> makeCells(const scene::Scene& scene, const CellConfig& config = {});

// The kd subdivision alone (also used for scenes with rooms by tests and callers that want it).
Result<Cells> kdCells(const scene::Scene& scene, const CellConfig& config = {});

// The cell of a point: the lowest-index box holding it (closed boxes), else the nearest box
// (ties to the lower index). Precondition: boxes is not empty.
uint32_t cellOfPoint(const std::vector<Aabb>& boxes, const Vec3& pos);

// For each cell, the cells whose boxes touch or overlap it within `tolerance` metres, ascending,
// without the cell itself.
std::vector<std::vector<uint32_t>> adjacentCells(const std::vector<Aabb>& boxes,
                                                 float tolerance = 1e-3f);

// Centroid of a global triangle. Precondition: triangle < scene.triangleCount().
Vec3 triangleCentroid(const scene::Scene& scene, uint32_t triangle);

}  // namespace plx::stream
