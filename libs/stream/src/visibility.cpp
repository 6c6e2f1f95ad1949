// PVS and ACH preprocessing (Marvie & Bouatouch section 5) on the software rasterizer's ID-only
// path: no colour target, and depth and IDs kept in the renderer's tile memory, the pixels'
// cells counted tile by tile while the tile is in cache (raster::TileIdVisitor).

#include <plx/stream/visibility.h>

#include <algorithm>
#include <atomic>
#include <memory>
#include <mutex>

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <plx/core/parallel.h>
#include <plx/raster/raster.h>

namespace plx::stream {
namespace {

// Radical inverse of i in `base`: the Halton sequence's coordinate.
float radicalInverse(uint32_t i, uint32_t base) {
    double inv = 1.0 / double(base), f = inv, r = 0.0;
    for (; i > 0; i /= base, f *= inv) r += f * double(i % base);
    return float(r);
}

using PixelCounts = std::vector<std::pair<uint32_t, uint64_t>>;  // (index, pixels) ascending

// The non-zero entries of a dense count array as (index, pixels) ascending; clears the array.
PixelCounts takeNonZero(std::vector<uint64_t>& counts) {
    PixelCounts out;
    for (size_t k = 0; k < counts.size(); ++k)
        if (counts[k] != 0) {
            out.emplace_back(uint32_t(k), counts[k]);
            counts[k] = 0;
        }
    return out;
}

// Per triangle, its material's base colour texture + 1, or 0 when untextured.
std::vector<uint32_t> textureOfTriangles(const scene::Scene& scene) {
    std::vector<uint32_t> out(scene.triangleCount(), 0);
    for (uint32_t t = 0; t < out.size(); ++t) {
        const int material = scene.meshes[scene.meshOfTriangle(t)].materialIndex;
        const int texture = material >= 0 && size_t(material) < scene.materials.size()
                                ? scene.materials[size_t(material)].baseColorTexture
                                : -1;
        out[t] = texture >= 0 ? uint32_t(texture) + 1 : 0;
    }
    return out;
}

// Counts each pixel's cell (Marvie eq. 1, N_ij summed over the cameras of one sample) and its
// texture into dense arrays; the renderer runs on one thread here, so one slot.
class CellCounter : public raster::TileIdVisitor {
public:
    CellCounter(const std::vector<uint32_t>& cellOfTriangle, size_t cellCount,
                const std::vector<uint32_t>& textureOfTriangle, size_t textureCount)
        : mCellOf(cellOfTriangle),
          mTextureOf(textureOfTriangle),
          mCells(cellCount, 0),
          mTextures(textureCount + 1, 0) {}

    void visitTile(const ImageView<uint32_t>& ids, int x0, int y0, int x1, int y1,
                   int /*slot*/) override {
        for (int y = y0; y <= y1; ++y) {
            const uint32_t* row = ids.row(y);
            for (int x = x0; x <= x1; ++x)
                if (row[x] != 0) {
                    ++mCells[mCellOf[row[x] - 1]];
                    ++mTextures[mTextureOf[row[x] - 1]];
                }
        }
    }

    // Moves the counts out (cells, then textures, untextured pixels dropped) and clears them.
    std::pair<PixelCounts, PixelCounts> take() {
        mTextures[0] = 0;
        PixelCounts textures = takeNonZero(mTextures);
        for (auto& [texture, pixels] : textures) --texture;
        return {takeNonZero(mCells), std::move(textures)};
    }

private:
    const std::vector<uint32_t>& mCellOf;
    const std::vector<uint32_t>& mTextureOf;
    std::vector<uint64_t> mCells, mTextures;
};

// One worker's renderer and counter, made on first use by each thread.
struct Worker {
    std::unique_ptr<raster::Renderer> renderer;
    std::unique_ptr<CellCounter> counter;
};

// The six cameras of a rendering box centred at eyePos (section 5: "the view direction of each
// camera is perpendicular to one face of a box", 90-degree field of view).
Result<std::vector<Camera>> renderingBox(const scene::Scene& scene, const Vec3& eyePos,
                                         int faceSize) {
    static const Vec3 kDirs[6] = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                  {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
    static const Vec3 kUps[6] = {{0, 1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}, {0, 1, 0}, {0, 1, 0}};
    std::vector<Camera> cameras;
    for (int f = 0; f < 6; ++f) {
        CameraDesc d;
        d.eyePos = eyePos;
        d.targetPos = targetAlong(eyePos, kDirs[f]);
        d.upDir = kUps[f];
        d.fovYDegrees = 90.0f;
        d.width = d.height = faceSize;
        scene::clipPlanesFor(scene.bounds(), eyePos, &d.nearPlane, &d.farPlane);
        auto camera = Camera::create(d);
        if (!camera) return camera.status();
        cameras.push_back(*camera);
    }
    return cameras;
}

// Pixels per cell and per texture seen from one sample point: the six faces rendered ID-only.
Result<std::pair<PixelCounts, PixelCounts>> sampleCoverage(const scene::Scene& scene,
                                                           const Vec3& eyePos, int faceSize,
                                                           Worker& worker) {
    auto cameras = renderingBox(scene, eyePos, faceSize);
    if (!cameras)
        return errorStatus(cameras.status().code(),
                           fmt::format("sample point ({:g}, {:g}, {:g}): {}", eyePos.x, eyePos.y,
                                       eyePos.z, cameras.status().message()));
    raster::RenderOptions options;
    options.clearTargets = true;
    raster::RenderTargets targets;  // no colour, depth or ID views: tile memory only
    targets.visibility.tileIds = worker.counter.get();
    for (const Camera& camera : *cameras) worker.renderer->render(scene, camera, options, targets);
    return worker.counter->take();
}

// Adds sparse ascending (index, pixels) lists: Marvie eq. 1 summed over samples.
void accumulate(PixelCounts* sum, const PixelCounts& add) {
    PixelCounts out;
    out.reserve(sum->size() + add.size());
    size_t i = 0, j = 0;
    while (i < sum->size() || j < add.size()) {
        if (j == add.size() || (i < sum->size() && (*sum)[i].first < add[j].first)) {
            out.push_back((*sum)[i++]);
        } else if (i == sum->size() || add[j].first < (*sum)[i].first) {
            out.push_back(add[j++]);
        } else {
            out.emplace_back(add[j].first, (*sum)[i].second + add[j].second);
            ++i, ++j;
        }
    }
    *sum = std::move(out);
}

Status checkRequest(const Cells& cells, const VisibilityConfig& config, uint32_t first,
                    uint32_t last) {
    if (config.samples < 1 || config.samples > kMaxSamples)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("samples {} outside 1..{}", config.samples, kMaxSamples));
    if (config.faceSize < kMinFaceSize || config.faceSize > kMaxFaceSize)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("face size {} outside {}..{}", config.faceSize, kMinFaceSize,
                                       kMaxFaceSize));
    if (!(config.margin >= 0.0f && config.margin < 0.5f))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("margin {} outside [0, 0.5)", config.margin));
    PLX_RETURN_IF_ERROR(checkThreadCount(config.threads, "threads"));
    if (first > last || last >= cells.boxes.size())
        return errorStatus(
            ErrorCode::kInvalidArgument,
            fmt::format("cell range {}-{} outside 0-{}", first, last, cells.boxes.size() - 1));
    return Status::ok();
}

}  // namespace

std::vector<Vec3> samplePoints(const Aabb& box, int samples, float margin) {
    PLX_CHECK(samples >= 1);
    const Vec3 lo = box.lo + margin * box.extent();
    const Vec3 size = (1.0f - 2.0f * margin) * box.extent();
    std::vector<Vec3> points;
    // Index i + 1 skips the Halton sequence's first point (0, 0, 0), a corner of the box.
    for (uint32_t i = 0; i < uint32_t(samples); ++i)
        points.push_back(lo + size * Vec3(radicalInverse(i + 1, 2), radicalInverse(i + 1, 3),
                                          radicalInverse(i + 1, 5)));
    return points;
}

Result<std::vector<CellVisibility>> computeVisibility(const scene::Scene& scene, const Cells& cells,
                                                      const VisibilityConfig& config,
                                                      uint32_t first, uint32_t last,
                                                      const std::function<void(size_t)>& progress) {
    PLX_RETURN_IF_ERROR(checkRequest(cells, config, first, last));
    const size_t cellCount = last - first + 1, samples = size_t(config.samples);
    // One slot per (cell, sample) pair, so that a range of one cell still uses every core.
    std::vector<std::pair<PixelCounts, PixelCounts>> perSample(cellCount * samples);
    const std::vector<uint32_t> textureOf = textureOfTriangles(scene);
    std::vector<std::vector<Vec3>> points(cellCount);
    for (size_t c = 0; c < cellCount; ++c)
        points[c] = samplePoints(cells.boxes[first + c], config.samples, config.margin);
    std::vector<std::atomic<int>> samplesLeft(cellCount);
    for (auto& s : samplesLeft) s.store(config.samples);
    std::atomic<size_t> cellsDone{0};
    std::mutex progressMutex;  // guards the progress callback and firstError
    std::atomic<bool> failed{false};
    Status firstError = Status::ok();
    tbb::enumerable_thread_specific<Worker> workers;
    ThreadPool pool(config.threads);
    pool.run([&] {
        tbb::parallel_for(
            tbb::blocked_range<size_t>(0, perSample.size(), 1),
            [&](const tbb::blocked_range<size_t>& r) {
                Worker& w = workers.local();
                if (!w.renderer) {
                    w.renderer = raster::Renderer::create({1, 128}).value();
                    w.counter = std::make_unique<CellCounter>(
                        cells.cellOfTriangle, cells.boxes.size(), textureOf, scene.textures.size());
                }
                for (size_t k = r.begin(); k < r.end() && !failed.load(); ++k) {
                    const size_t c = k / samples;
                    auto coverage =
                        sampleCoverage(scene, points[c][k % samples], config.faceSize, w);
                    if (!coverage) {
                        std::lock_guard lock(progressMutex);
                        if (!failed.exchange(true)) firstError = coverage.status();
                        return;
                    }
                    perSample[k] = std::move(*coverage);
                    if (samplesLeft[c].fetch_sub(1) == 1 && progress) {
                        std::lock_guard lock(progressMutex);
                        progress(++cellsDone);
                    }
                }
            });
    });
    if (failed) return firstError;
    // Sum the samples in a fixed order: the result does not depend on the schedule.
    std::vector<CellVisibility> result(cellCount);
    for (size_t c = 0; c < cellCount; ++c) {
        result[c].cell = uint32_t(first + c);
        for (size_t s = 0; s < samples; ++s) {
            accumulate(&result[c].seen, perSample[c * samples + s].first);
            accumulate(&result[c].textures, perSample[c * samples + s].second);
        }
    }
    return result;
}

std::vector<PvsEntry> pvsWithAch(const CellVisibility& visibility) {
    uint64_t total = 0;  // N_pixels^total, Marvie eq. 2
    for (const auto& [cell, pixels] : visibility.seen) total += pixels;
    std::vector<PvsEntry> pvs;
    bool self = false;
    for (const auto& [cell, pixels] : visibility.seen) {
        if (!self && cell > visibility.cell) {
            pvs.push_back({visibility.cell, 0, 0.0});
            self = true;
        }
        self = self || cell == visibility.cell;
        // ACH_j = N_j^total / N_pixels^total (Marvie eq. 3).
        pvs.push_back({cell, pixels, double(pixels) / double(total)});
    }
    if (!self) pvs.push_back({visibility.cell, 0, 0.0});
    if (total == 0)
        for (PvsEntry& e : pvs) e.ach = 1.0;  // only the cell itself: it takes the whole budget
    return pvs;
}

}  // namespace plx::stream
