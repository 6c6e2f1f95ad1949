// The tiled, multithreaded renderer.
//
// Three stages per frame, each parallel over independent work:
//  1. vertices: every vertex of every mesh to clip space, outcode, and (inside the guard band)
//     snapped fixed-point screen position;
//  2. binning: triangles in chunks of consecutive indices; each chunk culls, clips what needs it,
//     and appends surviving triangles to its own per-tile lists, so submission order survives;
//  3. tiles: each screen tile clears its rectangle, then walks the chunks in order and rasterises
//     their entries for that tile. Tiles own disjoint pixels, so no locks are needed. A tile
//     that starts from the clear values is drawn in its thread's own tile memory, which stays in
//     the core's cache, and streamed to the targets once finished (TileMemory).
// Subset rendering skips stage 1 and transforms the listed triangles' vertices in stage 2, so its
// cost follows the list length, not the scene size.

#include <algorithm>
#include <atomic>
#include <cstring>
#include <numeric>
#include <thread>
#include <utility>

#include <fmt/format.h>

#include <plx/core/parallel.h>

#include "bins.h"

namespace plx::raster {

using namespace detail;

namespace {

// Triangles per binning chunk: large enough to amortise the per-chunk, per-tile list overhead,
// small enough to give every thread several chunks on 100k-triangle scenes.
constexpr size_t kChunkTriangles = 8192;
// Subsets are short (a P-buffer's visible set is a few thousand triangles) and each of their
// triangles costs more (vertices transformed per triangle, scattered memory), so they are cut
// finer to keep every thread binning (chunks of at most this many, planChunks).
constexpr size_t kSubsetChunkTriangles = 512;
// The clear colour as the 32-bit word the colour target holds.
uint32_t clearWordOf(const RenderOptions& options) {
    static_assert(sizeof(Rgba8) == sizeof(uint32_t));
    uint32_t word;
    std::memcpy(&word, &options.clearColor, sizeof word);
    return word;
}

// The tiles one frame drew into on one set of targets, which left every other tile of them
// holding the clear values (RenderOptions::clearDrawnTilesOnly).
struct DrawnTiles {
    const void* data[5];  // colour, depth, ID, second depth, second ID (null when absent)
    ptrdiff_t strides[5];
    int width, height;
    uint32_t clearWord;
    bool colorOnly;
    std::vector<uint8_t> drawn;  // per tile

    static DrawnTiles keyOf(const RenderTargets& rt, const RenderOptions& options,
                            uint32_t clearWord) {
        return {{rt.color.data, rt.depth.data, rt.id.data, rt.visibility.depth2.data,
                 rt.visibility.id2.data},
                {rt.color.strideElems, rt.depth.strideElems, rt.id.strideElems,
                 rt.visibility.depth2.strideElems, rt.visibility.id2.strideElems},
                rt.depth.data ? rt.depth.width : rt.color.width,
                rt.depth.data ? rt.depth.height : rt.color.height,
                clearWord,
                options.colorOnly,
                {}};
    }
    bool sameTargets(const DrawnTiles& o) const {
        return std::equal(data, data + 5, o.data) && std::equal(strides, strides + 5, o.strides) &&
               width == o.width && height == o.height && clearWord == o.clearWord &&
               colorOnly == o.colorOnly;
    }
    bool sharesTarget(const DrawnTiles& o) const {
        for (const void* a : data)
            for (const void* b : o.data)
                if (a && a == b) return true;
        return false;
    }
};

// Targets whose drawn tiles are remembered at once (a two-pass renderer alternates two sets).
constexpr size_t kMaxDrawnRecords = 4;

// Largest tile drawn in tile memory: its three planes (depth, ID, colour; 192 KiB at 128) must
// stay in a core's own cache next to the tile's bins.
constexpr int kMaxTileMemorySize = 128;

// Waits until another thread sets `flag`: spinning with the pause hint where there is one (it
// frees the core's shared resources for the other hardware thread), then, should the wait run
// long (the other thread descheduled on a busy machine), yielding the core between looks.
inline void waitUntilSet(const std::atomic<bool>& flag) {
    constexpr int kSpins = 2048;
    for (int spin = 0; !flag.load(std::memory_order_acquire); ++spin) {
#if defined(__x86_64__) || defined(__i386__)
        if (spin < kSpins) {
            __builtin_ia32_pause();
            continue;
        }
#endif
        std::this_thread::yield();
    }
}

// Finds the mesh of each triangle of a subset by stepping on from the previous one's: the
// P-buffer's visible set is sorted, so its triangles walk the meshes in order, and a binary search
// per triangle (three per triangle with the prefetches) was a fifth of a P-buffer second eye's
// binning (callgrind, office:280). Other jumps (backwards, or past kMaxSteps meshes) search.
class MeshCursor {
public:
    explicit MeshCursor(const scene::Scene& scene) : mScene(scene) {}

    // The mesh holding global triangle `g`, and g's index inside it.
    const scene::Mesh& locate(uint32_t g, uint32_t* local) {
        constexpr int kMaxSteps = 8;
        const size_t meshes = mScene.meshes.size();
        int steps = 0;
        if (g < mScene.firstTriangle(mMesh)) {
            mMesh = mScene.meshOfTriangle(g);
        } else {
            while (mMesh + 1 < meshes && g >= mScene.firstTriangle(mMesh + 1)) {
                if (++steps > kMaxSteps) {
                    mMesh = mScene.meshOfTriangle(g);
                    break;
                }
                ++mMesh;
            }
        }
        *local = uint32_t(g - mScene.firstTriangle(mMesh));
        return mScene.meshes[mMesh];
    }
    size_t mesh() const { return mMesh; }

private:
    const scene::Scene& mScene;
    size_t mMesh = 0;
};

// One thread's tile memory: depth, ID and colour planes of one tile. A tile is drawn here
// through views that address it in frame coordinates, then streamed to the frame's targets.
//
// Why: a large scene's first pass leaves the caches full of its own data, and clearing a tile
// of a 640x480 frame's targets then waits for each of its lines to arrive from memory before
// rasterising can start (a quarter of a P-buffer stereo pair's second eye, docs/stereo-results.md).
// Here the clear and every depth test stay in this core's cache, and each target line is
// written once, by a streaming store that does not read it first.
//
// The planes are cleared once, whole; resolve() then puts the clear values back into every word
// it streams out, which are all the words a tile can have written, so the planes are clear again
// for the next tile without a separate pass.
class TileMemory {
public:
    // Views of this memory standing in for `frame`'s depth, ID and (when present) colour over the
    // tile whose top-left pixel is (x0, y0), the planes holding the clear values (depth and ID 0,
    // colour `clearWord`): row(y)[x] for x0 <= x < x0 + size, y0 <= y < y0 + size lands in the
    // tile's planes. The views' base pointers point before the planes; only the tile's own pixels
    // are ever addressed through them.
    // The depth and ID views stand in for the frame's also where the frame has none (the render
    // then drops them after the tile); `width` x `height` is the frame's image size.
    RenderTargets bindCleared(const RenderTargets& frame, int size, int x0, int y0, int width,
                              int height, uint32_t clearWord) {
        const size_t plane = size_t(size) * size_t(size);
        if (size != mSize) {
            mWords.assign(3 * plane, 0);
            mSize = size;
            mColorWord = 0;
        }
        if (frame.color.data && mColorWord != clearWord) {
            std::fill_n(mWords.data() + 2 * plane, plane, clearWord);
            mColorWord = clearWord;
        }
        RenderTargets tile = frame;
        const ptrdiff_t origin = ptrdiff_t(y0) * size + x0;
        tile.depth = view(reinterpret_cast<float*>(mWords.data()), origin, size, width, height);
        tile.id = view(mWords.data() + plane, origin, size, width, height);
        if (frame.color.data)
            tile.color = view(reinterpret_cast<Rgba8*>(mWords.data() + 2 * plane), origin, size,
                              width, height);
        return tile;
    }

    // The word the colour plane holds where it is clear.
    uint32_t colorWord() const { return mColorWord; }

private:
    template <class T>
    static ImageView<T> view(T* plane, ptrdiff_t origin, int size, int width, int height) {
        // The base is formed as an integer: it lies before the plane, outside any object.
        auto base = reinterpret_cast<T*>(reinterpret_cast<uintptr_t>(plane) -
                                         uintptr_t(origin) * sizeof(T));
        return {base, width, height, size};
    }

    std::vector<uint32_t> mWords;  // depth, ID, colour planes, size x size each
    int mSize = 0;                 // the planes' side
    uint32_t mColorWord = 0;       // the word the whole colour plane holds
};

}  // namespace

struct Renderer::Impl {
    RendererConfig config;
    ThreadPool pool;
    int tileShift = 6;
    std::vector<VertexOut> vertices;
    std::vector<size_t> meshVertexBase;
    std::vector<Chunk> chunks;
    size_t chunkCount = 0;
    // Coarse occlusion per 8x8 block; each tile touches only its own blocks (see DepthBlocks).
    mutable DepthBlocks blocks;
    mutable std::vector<uint64_t> occludedPerTile;  // this frame's tilePairsOccluded, per tile
    std::vector<DrawnTiles> drawnRecords;  // most recent last, at most kMaxDrawnRecords
    std::vector<uint8_t> clearTile;        // this frame: per tile, whether to clear it
    mutable std::vector<TileMemory> tileMemory;  // per thread slot
    RasterKernels kernels = RasterKernels::active();  // this frame's ISA path
    std::vector<uint32_t> tileOrder;             // this frame: the tiles, most binned pairs first
    std::vector<uint32_t> tilePairs;             // this frame: binned triangle-tile pairs per tile

    explicit Impl(const RendererConfig& c) : config(c), pool(c.threads) {
        while ((1 << tileShift) < c.tileSize) ++tileShift;
        while ((1 << tileShift) > c.tileSize) --tileShift;
    }

    RenderStats run(const scene::Scene& scene, const Camera& camera,
                    std::span<const uint32_t>* subset, const RenderOptions& options,
                    const RenderTargets& rt);
    void transformVertices(const scene::Scene& scene, const Camera& camera, const Viewport& vp);
    void planChunks(const scene::Scene& scene, std::span<const uint32_t>* subset, size_t tiles);
    void binChunk(Chunk& chunk, const scene::Scene& scene, const Camera& camera,
                  std::span<const uint32_t>* subset, const Viewport& vp, const ShadeContext& ctx,
                  int tilesX);
    void noteUnsampled(Chunk& chunk, const scene::Scene& scene, const RasterVertex v[3],
                       const Viewport& vp, const ShadeContext& ctx, uint32_t localTri) const;
    void collectUnsampled(const RenderTargets& rt, std::vector<uint32_t>* out) const;
    void addToBins(Chunk& chunk, const BinnedTri& tri, int minX, int minY, int maxX, int maxY,
                   int tilesX) const;
    void clipAndBin(Chunk& chunk, const scene::Scene& scene, const Camera& camera, size_t mesh,
                    uint32_t localTri, const Viewport& vp, const ShadeContext& ctx, int tilesX);
    void binMaterialised(Chunk& chunk, const scene::Scene& scene, size_t mesh, uint32_t localTri,
                         const RasterVertex tri[3], const Viewport& vp, const ShadeContext& ctx,
                         int tilesX) const;
    void binSubsetChunk(Chunk& chunk, const scene::Scene& scene, const Camera& camera,
                        std::span<const uint32_t> subset, const Viewport& vp,
                        const ShadeContext& ctx, int tilesX);
    void binAndDraw(const scene::Scene& scene, const Camera& camera,
                    std::span<const uint32_t>* subset, const Viewport& vp, const ShadeContext& ctx,
                    const RenderOptions& options, const RenderTargets& rt, int tilesX,
                    size_t tiles);
    void planClears(const RenderOptions& options, const RenderTargets& rt, size_t tiles);
    void orderTiles(size_t tiles);
    void rasterizeTile(int tile, int tilesX, const scene::Scene& scene, const Viewport& vp,
                       const ShadeContext& ctx, const RenderOptions& options,
                       const RenderTargets& frame) const;
};

Result<std::unique_ptr<Renderer>> Renderer::create(const RendererConfig& config) {
    if (config.tileSize < 8 || config.tileSize > 256 || (config.tileSize & (config.tileSize - 1)))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("tile size {} must be a power of two in [8, 256]",
                                       config.tileSize));
    PLX_RETURN_IF_ERROR(checkThreadCount(config.threads, "thread count"));
    return std::unique_ptr<Renderer>(new Renderer(std::make_unique<Impl>(config)));
}

Renderer::Renderer(std::unique_ptr<Impl> impl) : mImpl(std::move(impl)) {}
Renderer::~Renderer() = default;
int Renderer::threadCount() const { return mImpl->pool.threadCount(); }

RenderStats Renderer::render(const scene::Scene& scene, const Camera& camera,
                             const RenderOptions& options, const RenderTargets& targets) {
    return mImpl->run(scene, camera, nullptr, options, targets);
}

RenderStats Renderer::renderSubset(const scene::Scene& scene, const Camera& camera,
                                   std::span<const uint32_t> triangleIndices,
                                   const RenderOptions& options, const RenderTargets& targets) {
    for (uint32_t t : triangleIndices) PLX_CHECK(t < scene.triangleCount());
    return mImpl->run(scene, camera, &triangleIndices, options, targets);
}

RenderStats Renderer::Impl::run(const scene::Scene& scene, const Camera& camera,
                                std::span<const uint32_t>* subset, const RenderOptions& options,
                                const RenderTargets& rt) {
    checkRenderRequestOrDie(camera, options, rt);
    Stopwatch clock;
    kernels = RasterKernels::active();
    Viewport vp(camera);
    ShadeContext ctx(options, rt);
    int tileSize = 1 << tileShift;
    int tilesX = (vp.width + tileSize - 1) / tileSize,
        tilesY = (vp.height + tileSize - 1) / tileSize;
    size_t tiles = size_t(tilesX) * size_t(tilesY);

    blocks.resize(vp.width, vp.height);
    occludedPerTile.assign(tiles, 0);
    if (!subset) transformVertices(scene, camera, vp);
    planChunks(scene, subset, tiles);
    tileMemory.resize(size_t(pool.threadCount()));  // a no-op after the first frame
    binAndDraw(scene, camera, subset, vp, ctx, options, rt, tilesX, tiles);

    if (rt.visibility.unsampledVisible && !subset)
        collectUnsampled(rt, rt.visibility.unsampledVisible);

    RenderStats stats;
    stats.trianglesSubmitted = subset ? subset->size() : scene.triangleCount();
    for (size_t c = 0; c < chunkCount; ++c) {
        stats.trianglesClipped += chunks[c].clipped;
        stats.trianglesBinned += chunks[c].binned;
    }
    for (uint64_t n : occludedPerTile) stats.tilePairsOccluded += n;
    for (uint8_t c : clearTile) stats.tilesCleared += c;
    stats.milliseconds = clock.elapsedMs();
    return stats;
}

void Renderer::Impl::transformVertices(const scene::Scene& scene, const Camera& camera,
                                       const Viewport& vp) {
    meshVertexBase.resize(scene.meshes.size());
    size_t total = 0;
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
        meshVertexBase[m] = total;
        total += scene.meshes[m].vertexCount();
    }
    if (vertices.size() < total) vertices.resize(total);
    const Mat4 clipFromWorld = camera.clipFromWorld();
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
        const auto& positions = scene.meshes[m].positions;
        VertexOut* out = vertices.data() + meshVertexBase[m];
        pool.parallelFor(positions.size(), 16384, [&](size_t b, size_t e) {
            kernels.transformPositions(positions.data() + b, e - b, clipFromWorld, vp, out + b);
        });
    }
}

// Bins the chunks, then draws the tiles, in one parallel region: threads take chunks from one
// counter, the thread that bins the last chunk plans the clears and the tile order, and every
// thread then takes tiles from another counter once that plan is published. Why one region: two
// parallel loops handed the work to the pool twice a frame, and a thread started late in each;
// here a late thread joins whatever stage the others have reached. Limit: binning is still
// about a tenth of a P-buffer second eye.
void Renderer::Impl::binAndDraw(const scene::Scene& scene, const Camera& camera,
                                std::span<const uint32_t>* subset, const Viewport& vp,
                                const ShadeContext& ctx, const RenderOptions& options,
                                const RenderTargets& rt, int tilesX, size_t tiles) {
    std::atomic<size_t> nextChunk{0}, chunksBinned{0}, nextTile{0};
    std::atomic<bool> planned{false}, failed{false};
    auto plan = [&] {
        planClears(options, rt, tiles);
        orderTiles(tiles);
        planned.store(true, std::memory_order_release);
    };
    if (chunkCount == 0) plan();
    pool.parallelFor(size_t(pool.threadCount()), 1, [&](size_t, size_t) {
        try {
            for (size_t c; (c = nextChunk.fetch_add(1, std::memory_order_relaxed)) < chunkCount;) {
                binChunk(chunks[c], scene, camera, subset, vp, ctx, tilesX);
                // acq_rel: the last thread here sees every chunk's bins before it plans.
                if (chunksBinned.fetch_add(1, std::memory_order_acq_rel) + 1 == chunkCount) plan();
            }
        } catch (...) {
            // Release the waiting threads (there will be no plan) before the exception leaves
            // through the parallel loop.
            failed.store(true, std::memory_order_relaxed);
            planned.store(true, std::memory_order_release);
            throw;
        }
        // Only threads still binning keep the plan waiting, and they need nothing from us.
        waitUntilSet(planned);
        if (failed.load(std::memory_order_relaxed)) return;
        for (size_t i; (i = nextTile.fetch_add(1, std::memory_order_relaxed)) < tiles;)
            rasterizeTile(int(tileOrder[i]), tilesX, scene, vp, ctx, options, rt);
    });
}

void Renderer::Impl::planChunks(const scene::Scene& scene, std::span<const uint32_t>* subset,
                                size_t tiles) {
    chunkCount = 0;
    auto add = [&](size_t mesh, size_t begin, size_t end) {
        if (chunks.size() <= chunkCount) chunks.emplace_back();
        Chunk& c = chunks[chunkCount++];
        c.mesh = mesh;
        c.begin = begin;
        c.end = end;
        c.reset(tiles);
    };
    if (subset) {
        // Equal chunks, a whole number of them per thread: 1,123 triangles in chunks of 512 left
        // one thread a chunk and a half to bin while the other had one.
        const size_t n = subset->size(), threads = size_t(pool.threadCount());
        const size_t perThread = std::max<size_t>(
            1, (n + threads * kSubsetChunkTriangles - 1) / (threads * kSubsetChunkTriangles));
        const size_t count = threads * perThread;
        const size_t size = std::max<size_t>(1, (n + count - 1) / count);
        for (size_t b = 0; b < n; b += size) add(0, b, std::min(n, b + size));
        return;
    }
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
        size_t n = scene.meshes[m].triangleCount();
        for (size_t b = 0; b < n; b += kChunkTriangles) add(m, b, std::min(n, b + kChunkTriangles));
    }
}

// Threads take tiles from one shared counter, the tiles with the most binned triangle-tile pairs
// first (longest processing time first), so that the last tiles drawn are short ones and no
// thread waits long at the end for another's large tile: the far furniture of an office at the
// top of the image holds several times the pairs of the bare floor at the bottom. This order left
// the threads idle least of TBB's range splitting and a counter in image order.
void Renderer::Impl::orderTiles(size_t tiles) {
    tilePairs.assign(tiles, 0);
    for (size_t c = 0; c < chunkCount; ++c)
        for (size_t t = 0; t < tiles; ++t) tilePairs[t] += uint32_t(chunks[c].bins[t].size());
    tileOrder.resize(tiles);
    std::iota(tileOrder.begin(), tileOrder.end(), 0u);
    std::stable_sort(tileOrder.begin(), tileOrder.end(),
                     [&](uint32_t a, uint32_t b) { return tilePairs[a] > tilePairs[b]; });
}

void Renderer::Impl::addToBins(Chunk& chunk, const BinnedTri& tri, int minX, int minY, int maxX,
                               int maxY, int tilesX) const {
    int tx0 = minX >> tileShift, tx1 = maxX >> tileShift;
    int ty0 = minY >> tileShift, ty1 = maxY >> tileShift;
    ++chunk.binned;
    if (tx0 == tx1 && ty0 == ty1) {  // most triangles of dense meshes
        chunk.bins[size_t(ty0) * tilesX + tx0].push_back(tri);
        return;
    }
    for (int ty = ty0; ty <= ty1; ++ty)
        for (int tx = tx0; tx <= tx1; ++tx) chunk.bins[size_t(ty) * tilesX + tx].push_back(tri);
}

void Renderer::Impl::noteUnsampled(Chunk& chunk, const scene::Scene& scene,
                                   const RasterVertex v[3], const Viewport& vp,
                                   const ShadeContext& ctx, uint32_t localTri) const {
    int64_t area2 = int64_t(v[1].x - v[0].x) * (v[2].y - v[0].y) -
                    int64_t(v[1].y - v[0].y) * (v[2].x - v[0].x);
    if (area2 == 0 || (ctx.cullBackFaces && area2 > 0)) return;
    int32_t cx = int32_t((int64_t(v[0].x) + v[1].x + v[2].x) / 3) >> kSubPixelBits;
    int32_t cy = int32_t((int64_t(v[0].y) + v[1].y + v[2].y) / 3) >> kSubPixelBits;
    if (cx < 0 || cy < 0 || cx >= vp.width || cy >= vp.height) return;
    float maxInvW = std::max({v[0].invW, v[1].invW, v[2].invW});
    chunk.unsampled.push_back(
        {uint32_t(scene.firstTriangle(chunk.mesh) + localTri), cx, cy, maxInvW});
}

void Renderer::Impl::collectUnsampled(const RenderTargets& rt, std::vector<uint32_t>* out) const {
    for (size_t c = 0; c < chunkCount; ++c) {
        for (const Unsampled& u : chunks[c].unsampled) {
            // Nearer than the surface drawn at any of the 3x3 pixels around it (or next to empty
            // background): a slightly shifted sampling, such as the other eye's, could show it.
            bool visible = false;
            for (int dy = -1; dy <= 1 && !visible; ++dy) {
                int y = u.y + dy;
                if (y < 0 || y >= rt.depth.height) continue;
                for (int dx = -1; dx <= 1; ++dx) {
                    int x = u.x + dx;
                    if (x < 0 || x >= rt.depth.width) continue;
                    if (u.maxInvW > rt.depth.row(y)[x]) {
                        visible = true;
                        break;
                    }
                }
            }
            if (visible) out->push_back(u.globalTri);
        }
    }
}

namespace {
BinnedTri makeBinned(const RasterVertex v[3], uint32_t ref) {
    return {{v[0].x, v[1].x, v[2].x}, {v[0].y, v[1].y, v[2].y},
            {v[0].invW, v[1].invW, v[2].invW}, ref};
}
}  // namespace

void Renderer::Impl::clipAndBin(Chunk& chunk, const scene::Scene& scene, const Camera& camera,
                                size_t mesh, uint32_t localTri, const Viewport& vp,
                                const ShadeContext& ctx, int tilesX) {
    const scene::Mesh& m = scene.meshes[mesh];
    Vec4 clip[3];
    uint32_t codes[3];
    for (int k = 0; k < 3; ++k) {
        clip[k] =
            camera.clipFromWorld() * Vec4(m.positions[m.indices[3 * size_t(localTri) + k]], 1.0f);
        codes[k] = outcode(clip[k], vp);
    }
    if (codes[0] & codes[1] & codes[2] & kOutFrustum) return;
    if ((codes[0] | codes[1] | codes[2]) & kOutNeedsClip) {
        // Only here the room for clipTriangle's output, whose vertices are zeroed on declaration.
        RasterVertex tris[kMaxClippedTriangles][3];
        const int count = clipTriangle(clip, vp, tris);
        ++chunk.clipped;
        for (int i = 0; i < count; ++i)
            binMaterialised(chunk, scene, mesh, localTri, tris[i], vp, ctx, tilesX);
        return;
    }
    RasterVertex tri[3];
    for (int k = 0; k < 3; ++k) tri[k] = snapVertex(clip[k], vp, Vec3(k == 0, k == 1, k == 2));
    binMaterialised(chunk, scene, mesh, localTri, tri, vp, ctx, tilesX);
}

void Renderer::Impl::binMaterialised(Chunk& chunk, const scene::Scene& scene, size_t mesh,
                                     uint32_t localTri, const RasterVertex tri[3],
                                     const Viewport& vp, const ShadeContext& ctx,
                                     int tilesX) const {
    int minX, minY, maxX, maxY;
    if (!triangleBounds(tri[0], tri[1], tri[2], vp, ctx.cullBackFaces, &minX, &minY, &maxX, &maxY))
        return;
    uint32_t index = uint32_t(chunk.materialised.size());
    Rgba8 flat = ctx.shading == Shading::kFlat ? flatColorOf(scene, mesh, localTri, ctx) : Rgba8{};
    chunk.materialised.push_back(
        {uint32_t(mesh), localTri, {tri[0].bary, tri[1].bary, tri[2].bary}, flat});
    addToBins(chunk, makeBinned(tri, index | kMaterialisedBit), minX, minY, maxX, maxY, tilesX);
}

// A subset's triangles in batches of kSubsetBatch: their corners gathered and transformed
// together by transformPositions (eight at a time with AVX2, the same bits as one at a time),
// each triangle then binned as a materialised entry, or clipped by clipAndBin when a corner
// needs it. One at a time through clipAndBin's three matrix products, outcodes and snaps, the
// binning of office:280's 1,123 visible triangles took 0.89M instructions; it takes 0.72M.
void Renderer::Impl::binSubsetChunk(Chunk& chunk, const scene::Scene& scene, const Camera& camera,
                                    std::span<const uint32_t> subset, const Viewport& vp,
                                    const ShadeContext& ctx, int tilesX) {
    // A subset is scattered over a scene that may be far larger than the caches, so each
    // triangle's indices and positions are cache misses. Prefetch indices kIndexAhead
    // triangles ahead and, once those have arrived, positions kPositionAhead ahead.
    constexpr size_t kIndexAhead = 16, kPositionAhead = 8, kSubsetBatch = 8;
    MeshCursor indexAhead(scene), positionAhead(scene), current(scene);
    for (size_t b = chunk.begin; b < chunk.end; b += kSubsetBatch) {
        const size_t n = std::min(kSubsetBatch, chunk.end - b);
        Vec3 corners[3 * kSubsetBatch];
        uint32_t locals[kSubsetBatch];
        size_t meshes[kSubsetBatch];
        for (size_t j = 0; j < n; ++j) {
            const size_t i = b + j;
            uint32_t local;
            if (i + kIndexAhead < chunk.end) {
                const scene::Mesh& ahead = indexAhead.locate(subset[i + kIndexAhead], &local);
                __builtin_prefetch(&ahead.indices[3 * size_t(local)]);
            }
            if (i + kPositionAhead < chunk.end) {
                const scene::Mesh& ahead = positionAhead.locate(subset[i + kPositionAhead], &local);
                for (int k = 0; k < 3; ++k)
                    __builtin_prefetch(&ahead.positions[ahead.indices[3 * size_t(local) + k]]);
            }
            const scene::Mesh& m = current.locate(subset[i], &locals[j]);
            meshes[j] = current.mesh();
            for (int k = 0; k < 3; ++k)
                corners[3 * j + size_t(k)] = m.positions[m.indices[3 * size_t(locals[j]) + k]];
        }
        VertexOut out[3 * kSubsetBatch];
        kernels.transformPositions(corners, 3 * n, camera.clipFromWorld(), vp, out);
        for (size_t j = 0; j < n; ++j) {
            const VertexOut* c = out + 3 * j;
            if (c[0].code & c[1].code & c[2].code & kOutFrustum) continue;
            if ((c[0].code | c[1].code | c[2].code) & kOutNeedsClip) {
                // Clipping needs the clip-space corners, which clipAndBin computes again.
                clipAndBin(chunk, scene, camera, meshes[j], locals[j], vp, ctx, tilesX);
                continue;
            }
            RasterVertex v[3];
            for (int k = 0; k < 3; ++k)
                v[k] = {c[k].x, c[k].y, c[k].invW, Vec3(k == 0, k == 1, k == 2)};
            binMaterialised(chunk, scene, meshes[j], locals[j], v, vp, ctx, tilesX);
        }
    }
}

void Renderer::Impl::binChunk(Chunk& chunk, const scene::Scene& scene, const Camera& camera,
                              std::span<const uint32_t>* subset, const Viewport& vp,
                              const ShadeContext& ctx, int tilesX) {
    if (subset) {
        binSubsetChunk(chunk, scene, camera, *subset, vp, ctx, tilesX);
        return;
    }
    const scene::Mesh& mesh = scene.meshes[chunk.mesh];
    const VertexOut* verts = vertices.data() + meshVertexBase[chunk.mesh];
    const uint32_t* indices = mesh.indices.data();
    for (size_t t = chunk.begin; t < chunk.end; ++t) {
        const VertexOut& a = verts[indices[3 * t]];
        const VertexOut& b = verts[indices[3 * t + 1]];
        const VertexOut& c = verts[indices[3 * t + 2]];
        if (a.code & b.code & c.code & kOutFrustum) continue;
        if ((a.code | b.code | c.code) & kOutNeedsClip) {
            clipAndBin(chunk, scene, camera, chunk.mesh, uint32_t(t), vp, ctx, tilesX);
            continue;
        }
        RasterVertex v[3] = {
            {a.x, a.y, a.invW, {}}, {b.x, b.y, b.invW, {}}, {c.x, c.y, c.invW, {}}};
        int minX, minY, maxX, maxY;
        if (!triangleBounds(v[0], v[1], v[2], vp, ctx.cullBackFaces, &minX, &minY, &maxX, &maxY)) {
            if (ctx.collectUnsampled) noteUnsampled(chunk, scene, v, vp, ctx, uint32_t(t));
            continue;
        }
        addToBins(chunk, makeBinned(v, uint32_t(t)), minX, minY, maxX, maxY, tilesX);
    }
}

// Decides which tiles this frame clears (all, unless clearDrawnTilesOnly finds the targets' last
// frame) and remembers the tiles it draws into for the next frame on the same targets.
void Renderer::Impl::planClears(const RenderOptions& options, const RenderTargets& rt,
                                size_t tiles) {
    clearTile.assign(tiles, options.clearTargets ? 1 : 0);
    // Only a frame that clears and asks for it is remembered (what the untouched tiles of a
    // frame without clearTargets hold is the caller's).
    const bool remember = options.clearTargets && options.clearDrawnTilesOnly;
    if (!remember && drawnRecords.empty()) return;
    DrawnTiles now = DrawnTiles::keyOf(rt, options, clearWordOf(options));
    if (remember) {
        now.drawn.assign(tiles, 0);
        for (size_t t = 0; t < tiles; ++t)
            for (size_t c = 0; c < chunkCount && !now.drawn[t]; ++c)
                now.drawn[t] = chunks[c].bins[t].empty() ? 0 : 1;
        for (const DrawnTiles& last : drawnRecords)
            if (last.sameTargets(now) && last.drawn.size() == tiles)
                for (size_t t = 0; t < tiles; ++t) clearTile[t] = last.drawn[t] | now.drawn[t];
    }
    // Whatever this frame leaves in targets shared with a record makes that record stale.
    std::erase_if(drawnRecords, [&](const DrawnTiles& r) { return r.sharesTarget(now); });
    if (!remember) return;
    if (drawnRecords.size() == kMaxDrawnRecords) drawnRecords.erase(drawnRecords.begin());
    drawnRecords.push_back(std::move(now));
}

void Renderer::Impl::rasterizeTile(int tile, int tilesX, const scene::Scene& scene,
                                   const Viewport& vp, const ShadeContext& ctx,
                                   const RenderOptions& options,
                                   const RenderTargets& frame) const {
    int tileSize = 1 << tileShift;
    int x0 = (tile % tilesX) * tileSize, y0 = (tile / tilesX) * tileSize;
    int x1 = std::min(x0 + tileSize, vp.width) - 1, y1 = std::min(y0 + tileSize, vp.height) - 1;
    // Threads outside the pool's arena only run tiles when the loop runs inline, alone.
    const int slot = std::clamp(currentThreadSlot(), 0, pool.threadCount() - 1);
    // Tile memory holds no earlier contents, so only tiles that start from the clear values use
    // it; a second depth layer keeps its four planes in the targets. Without a depth or ID target
    // it is the only place for them, whatever the tile size (checkRenderRequest: such renders
    // clear their targets and have no second layer).
    const bool discards = !options.colorOnly && (!frame.depth.data || !frame.id.data);
    const bool inTileMemory =
        discards || (clearTile[size_t(tile)] && !options.colorOnly && !frame.visibility.id2.data &&
                     tileSize <= kMaxTileMemorySize);
    const uint32_t clearWord = clearWordOf(options);
    TileJob job;
    job.scene = &scene;
    job.vp = &vp;
    job.ctx = &ctx;
    job.chunks = chunks.data();
    job.chunkCount = chunkCount;
    job.tile = size_t(tile);
    job.x0 = x0, job.y0 = y0, job.x1 = x1, job.y1 = y1;
    job.rt = inTileMemory ? tileMemory[size_t(slot)].bindCleared(frame, tileSize, x0, y0,
                                                                  vp.width, vp.height, clearWord)
                          : frame;
    job.clear = clearTile[size_t(tile)] && !inTileMemory;
    job.clearWord = clearWord;
    // The second depth layer needs the hidden triangles too: no occlusion culling for it, nor
    // without a depth test.
    job.occlusion = job.rt.visibility.id2.data || options.colorOnly ? nullptr : &blocks;
    if (job.occlusion) blocks.reset(x0, y0, x1, y1, options.clearTargets);
    occludedPerTile[size_t(tile)] += kernels.drawTile(job);
    if (frame.visibility.tileIds)
        frame.visibility.tileIds->visitTile(job.rt.id, x0, y0, x1, y1, slot);
    if (inTileMemory)
        kernels.resolveTileMemory(job.rt, frame, x0, y0, x1, y1,
                                  tileMemory[size_t(slot)].colorWord());
}

}  // namespace plx::raster
