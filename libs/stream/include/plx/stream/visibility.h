#pragma once
// PVS and Average Coverage Hints (Marvie & Bouatouch section 5): from sample points spread over
// each cell, the six 90-degree cameras of a rendering box draw the scene into the polygon-ID
// target; each pixel's polygon maps to its cell; the cells seen form the PVS and each one's pixel
// count over the total is its ACH (eqs. 1-3).

#include <cstdint>
#include <functional>
#include <vector>

#include <plx/core/core.h>
#include <plx/scene/scene.h>
#include <plx/stream/cells.h>

namespace plx::stream {

constexpr int kMaxSamples = 1024;
constexpr int kMinFaceSize = 8;
constexpr int kMaxFaceSize = 4096;

struct VisibilityConfig {
    // Rendering boxes per cell; the paper uses eight, "uniformly distributed inside the cell".
    int samples = 8;
    // Side of each square camera face in pixels. 128 by measurement (docs/stream-results.md):
    // at eight samples it finds the same PVS as 256 on museum:64 and office:16, in half the time;
    // at 64 samples it misses 19 of 2,416 PVS entries on museum:64.
    int faceSize = 128;
    // Sample points stay this fraction of the cell's extent away from its faces (per axis), so
    // that they do not sit inside the walls on a room's boundary.
    float margin = 0.05f;
    int threads = 0;  // 0: all hardware threads (oneTBB)
};

// What the sampling of one cell saw: N_j^total (Marvie eq. 1) for every cell j with at least one
// pixel, sorted by j; and, beyond the paper, the same count per texture: the pixels whose
// polygon's material takes its base colour from texture t, over all cells (texture coverage
// hints: the ACH of eq. 3 with textures in place of cells).
struct CellVisibility {
    uint32_t cell = 0;
    std::vector<std::pair<uint32_t, uint64_t>> seen;      // (cell j, pixels > 0), ascending j
    std::vector<std::pair<uint32_t, uint64_t>> textures;  // (texture t, pixels > 0), ascending t
};

// One PVS entry: a cell, its pixel count and ACH_j = pixels / total (Marvie eq. 3).
struct PvsEntry {
    uint32_t cell = 0;
    uint64_t pixels = 0;
    double ach = 0.0;
};

// The sample points of a cell box: a Halton sequence (bases 2, 3, 5) over the box shrunk by
// `margin` of its extent on each side, so that any count spreads evenly and a denser sampling
// keeps the sparser one's points (its first `samples` points). Preconditions: samples >= 1.
std::vector<Vec3> samplePoints(const Aabb& box, int samples, float margin);

// Computes the visibility of cells first..last (inclusive), in parallel over (cell, sample)
// pairs; `progress`, when set, is called (from any thread, serialised) with the number of cells
// finished so far. The result is the same for any thread count.
// Errors: config out of range; first > last or last >= cell count; a sample point no camera
// can take (the first one found, with its position).
Result<std::vector<CellVisibility>> computeVisibility(
    const scene::Scene& scene, const Cells& cells, const VisibilityConfig& config, uint32_t first,
    uint32_t last, const std::function<void(size_t)>& progress = {});

// The PVS of a cell with its ACHs (Marvie eqs. 2-3): the cells seen plus the cell itself (with
// 0 pixels when unseen), ascending; the ACHs sum to 1 (the cell itself gets 1 when nothing was
// seen at all).
std::vector<PvsEntry> pvsWithAch(const CellVisibility& visibility);

}  // namespace plx::stream
