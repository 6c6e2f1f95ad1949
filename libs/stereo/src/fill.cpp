// Hole filling of the reproject method (Fu, Bao, Peng section 3): expansion holes from their
// polygon, disocclusion holes by the pruned front-to-back BSP search. See fill.h.

#include <plx/stereo/fill.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <span>
#include <utility>

#include <plx/raster/span_fill.h>
#include <plx/stereo/stereo.h>

#include "box_search.h"
#include "polygon_spans.h"

namespace plx::stereo {

using raster::PixelSpan;

namespace {

// FillScene::bsp and fragmentsOfTriangle.
Status buildBsp(const scene::Scene& scene, const scene::BspConfig& config, FillScene* fill) {
    auto tree = scene::BspTree::build(scene, config);
    if (!tree) return tree.status();
    fill->bsp = std::move(tree).value();
    fill->fragmentsOfTriangle.assign(scene.triangleCount(), 0);
    for (size_t f = 0; f < fill->bsp.fragmentCount(); ++f) {
        uint16_t& n = fill->fragmentsOfTriangle[fill->bsp.fragment(f).sourceTriangle];
        if (n < std::numeric_limits<uint16_t>::max()) ++n;
    }
    fill->bspBuilt = true;
    return Status::ok();
}

}  // namespace

Result<FillScene> buildFillScene(const scene::Scene& scene, FillSearch search,
                                 const scene::BspConfig& bsp,
                                 const scene::BoxHierarchyConfig& boxes, ThreadPool* pool) {
    FillScene fill;
    if (search == FillSearch::kBspOrder)
        if (Status s = buildBsp(scene, bsp, &fill); !s.isOk()) return s;
    auto hierarchy = scene::BoxHierarchy::build(scene, boxes, pool);
    if (!hierarchy) return hierarchy.status();
    fill.boxes = std::move(hierarchy).value();
    const std::vector<uint32_t>& order = fill.boxes.triangles();
    // The corners in leaf order, then the padding: copies of the last entry's.
    LeafCorners& corners = fill.boxCorners;
    const size_t entries = order.empty() ? 0 : order.size() + LeafCorners::kPadding;
    for (auto* axis : {&corners.x, &corners.y, &corners.z})
        for (std::vector<float>& coordinate : *axis) coordinate.resize(entries);
    for (size_t i = 0; i < entries; ++i) {
        const std::array<Vec3, 3> c = scene.triangleCorners(order[std::min(i, order.size() - 1)]);
        for (size_t k = 0; k < 3; ++k) {
            corners.x[k][i] = c[k].x;
            corners.y[k][i] = c[k].y;
            corners.z[k][i] = c[k].z;
        }
    }
    fill.wideBoxes = collapseFourWide(fill.boxes);
    return fill;
}

bool trianglesOfOneSurface(const scene::Scene& scene, uint32_t a, uint32_t b) {
    if (a == b || a >= scene.triangleCount() || b >= scene.triangleCount()) return false;
    const std::array<Vec3, 3> ca = scene.triangleCorners(a), cb = scene.triangleCorners(b);
    int shared = 0;
    for (const Vec3& p : ca) shared += p == cb[0] || p == cb[1] || p == cb[2];
    if (shared >= 2) return true;
    // One plane: b's corners within a small fraction of the triangles' size of a's plane.
    const Vec3 normal = cross(ca[1] - ca[0], ca[2] - ca[0]);
    const float area2 = length(normal);
    if (!(area2 > 0.0f)) return false;
    float size = 0.0f;
    for (int k = 0; k < 3; ++k)
        size = std::max({size, length(ca[k] - ca[(k + 1) % 3]), length(cb[k] - cb[(k + 1) % 3])});
    const float tolerance = kOneSurfacePlaneTolerance * size;
    for (const Vec3& p : cb)
        if (std::fabs(dot(normal, p - ca[0])) / area2 > tolerance) return false;
    return true;
}

// A split triangle drawn into the current piece, and how many of its fragments the walk has yet
// to pass; while that is above 0 the pixels it covers stay open (fill.h: split triangles). A
// triangle of one fragment is reached once, so it needs no entry.
struct DrawnTriangle {
    uint32_t triangle;
    uint32_t fragmentsLeft;
};

// A piece: the pixels of one hole inside one kFillTile tile.
struct FillPiece {
    uint32_t firstSpan = 0;  // into HolePieces::spans, row order
    uint32_t spanCount = 0;
    int64_t pixels = 0;
};

// The pieces of the hole being filled.
struct HolePieces {
    std::vector<PixelSpan> spans;
    std::vector<FillPiece> pieces;
    std::vector<std::pair<uint32_t, PixelSpan>> tiled;  // (tile column, span) of one tile row
    std::vector<uint32_t> columnStart;                  // cutIntoTiles' counting sort
};

struct FillScratch::Slot {
    scene::HoleFlags flags;
    HolePieces pieces;
    std::vector<PixelSpan> spans, next;  // the piece's open segments, and the next list
    std::vector<PixelSpan> searched;     // the segments an expansion left open
    std::vector<DrawnTriangle> drawn;
    FillStats stats;
};

FillScratch::FillScratch() = default;
FillScratch::~FillScratch() = default;

namespace {

// One frame's inputs, shared by every hole.
struct FillFrame {
    const scene::Scene& scene;
    const FillScene& fill;
    const Camera& camera;
    const FillOptions& options;
    const SecondEyeTargets& second;
    const HoleSet& holes;
    raster::RenderTargets targets;
    ImageView<uint8_t> holeClass;
};

class HoleFiller {
public:
    HoleFiller(const FillFrame& frame, FillScratch::Slot& slot) : mFrame(frame), mSlot(slot) {}

    void fill(const Hole& hole, std::span<const PixelSpan> piece, int64_t pixels) {
        mSlot.spans.assign(piece.begin(), piece.end());
        mSlot.drawn.clear();
        mOpen = pixels;
        if (hole.holeClass == HoleClass::kExpansion) {
            if (hole.polygonCount <= 1) {
                drawExpansion(hole.polygonId - 1);
            } else {
                const SurfacePolygons polygons = surfacePolygons(hole);
                for (int i = 0; i < polygons.count && mOpen > 0; ++i)
                    drawExpansion(polygons.ids[size_t(i)] - 1);
            }
        }
        // What the steps below draw lies inside the segments open now, so the pixels outside
        // them are the expansion's.
        const bool expanded = mOpen < pixels;
        if (expanded) mSlot.searched.assign(mSlot.spans.begin(), mSlot.spans.end());
        if (mOpen > 0 && hole.holeClass == HoleClass::kDisocclusion &&
            mFrame.options.surroundingFirst)
            drawSurroundingPolygons(hole);
        if (mOpen > 0) {
            if (mFrame.options.search == FillSearch::kBspOrder) {
                search(FrontBound(mFrame.camera, frontInvW(hole)));
            } else {
                const BoxSearchFrame frame{mFrame.scene,          mFrame.fill,    mFrame.camera,
                                           mFrame.options.render, mFrame.targets, frontInvW(hole)};
                searchBoxHierarchy(frame, mSlot.spans, &mSlot.stats);
            }
        }
        classify(piece, expanded ? std::span<const PixelSpan>(mSlot.searched) : piece, expanded);
    }

private:
    struct SurfacePolygons {
        std::array<uint32_t, kMaxSurfacePolygons> ids{};
        int count = 0;
    };
    // The distinct IDs (at most kMaxSurfacePolygons) beside the ends of a hole's segments: for an
    // expansion hole the triangles classifyHoles joined into it.
    SurfacePolygons surfacePolygons(const Hole& hole) const {
        SurfacePolygons out;
        auto add = [&](uint32_t id) {
            for (int i = 0; i < out.count; ++i)
                if (out.ids[size_t(i)] == id) return;
            if (id != 0 && out.count < kMaxSurfacePolygons) out.ids[size_t(out.count++)] = id;
        };
        for (int32_t s = hole.firstSegment; s < hole.firstSegment + hole.segmentCount; ++s) {
            const HoleSegment& seg = mFrame.holes.segments[size_t(s)];
            if (seg.xStart > 0) add(mFrame.targets.id.at(seg.xStart - 1, seg.y));
            if (seg.xEnd + 1 < mFrame.camera.width())
                add(mFrame.targets.id.at(seg.xEnd + 1, seg.y));
        }
        return out;
    }

    // FillOptions::surroundingFirst: the polygons around the hole over its open pixels, each
    // pixel final when first covered.
    void drawSurroundingPolygons(const Hole& hole) {
        const SurfacePolygons polygons = surfacePolygons(hole);
        for (int i = 0; i < polygons.count && mOpen > 0; ++i) {
            ++mSlot.stats.polygonsDrawn;
            if (raster::drawTriangleInSpans(mFrame.scene, polygons.ids[size_t(i)] - 1,
                                            mFrame.camera, mFrame.options.render, mFrame.targets,
                                            mSlot.spans) > 0)
                shrink();
        }
    }

    // nearestNeighbourInvW of the hole, found once for the consecutive pieces of one hole: each
    // piece of a large hole would otherwise read the neighbours of all its segments.
    float frontInvW(const Hole& hole) {
        if (&hole != mFrontOf) {
            mFrontOf = &hole;
            mFrontInvW = nearestNeighbourInvW(hole);
        }
        return mFrontInvW;
    }

    // The largest 1/w beside the ends of the hole's segments: the nearest of the polygons
    // surrounding it. 0 for a hole at the image border (no front bound, box_search.h).
    float nearestNeighbourInvW(const Hole& hole) const {
        if (hole.box.x0 == 0 || hole.box.x1 == mFrame.camera.width() - 1) return 0.0f;
        float nearest = 0.0f;
        for (int32_t s = hole.firstSegment; s < hole.firstSegment + hole.segmentCount; ++s) {
            const HoleSegment& seg = mFrame.holes.segments[size_t(s)];
            nearest = std::max({nearest, mFrame.targets.depth.at(seg.xStart - 1, seg.y),
                                mFrame.targets.depth.at(seg.xEnd + 1, seg.y)});
        }
        return nearest;
    }

    // The paper's expansion fill, by evaluation: the hole's one polygon over its segments.
    void drawExpansion(uint32_t triangle) {
        int64_t written =
            raster::drawTriangleInSpans(mFrame.scene, triangle, mFrame.camera,
                                        mFrame.options.render, mFrame.targets, mSlot.spans);
        if (written == 0) return;
        mSlot.stats.expansionPixels += written;
        shrink();
    }

    // Steps 1-5 of fill.h over the open segments, from the polygons surrounding the hole back.
    void search(const FrontBound& front) {
        const scene::PixelRect openBox = openRect();  // bounds the spans as they shrink, too
        const scene::RectFrustum frustum(mFrame.camera, openBox);
        scene::HoleQueryStats query;
        mFrame.fill.boxes.markHole(frustum, &mSlot.flags, &query);
        mSlot.stats.boxNodesTested += query.nodesTested;
        const scene::BspTree& bsp = mFrame.fill.bsp;
        auto acceptSubtree = [&](int32_t, const Aabb& box) {
            return !box.isEmpty() && frustum.mayCoverBox(box) && !front.inFront(box);
        };
        auto visit = [&](uint32_t fragment) {
            const uint32_t tri = bsp.fragment(fragment).sourceTriangle;
            if (!mSlot.flags.mayCover(tri)) return true;
            const uint32_t fragments = mFrame.fill.fragmentsOfTriangle[tri];
            if (fragments > 1) {
                if (DrawnTriangle* d = findDrawn(tri)) {
                    // A later fragment of a split triangle already drawn: passed, not drawn again.
                    if (d->fragmentsLeft > 0 && --d->fragmentsLeft == 0) shrink();
                    return mOpen > 0;
                }
            }
            ++mSlot.stats.polygonsTested;
            if (!frustum.mayCoverPoints(bsp.fragmentVertices(fragment))) return true;
            // Wholly in front of the surrounding polygons (after the bookkeeping above, so that a
            // drawn split triangle still counts this fragment as passed).
            if (front.inFront(bsp.fragmentVertices(fragment))) return true;
            if (!polygonMayCoverSpans(mFrame.camera, bsp.fragmentVertices(fragment), mSlot.spans,
                                      openBox))
                return true;
            ++mSlot.stats.polygonsDrawn;
            if (fragments > 1) mSlot.drawn.push_back({tri, fragments - 1});
            if (raster::drawTriangleInSpans(mFrame.scene, tri, mFrame.camera, mFrame.options.render,
                                            mFrame.targets, mSlot.spans) > 0)
                shrink();
            return mOpen > 0;
        };
        mSlot.stats.nodesVisited +=
            bsp.forEachFrontToBackPruned(mFrame.camera.eyePos(), acceptSubtree, visit);
    }

    DrawnTriangle* findDrawn(uint32_t triangle) {
        for (DrawnTriangle& d : mSlot.drawn)
            if (d.triangle == triangle) return &d;
        return nullptr;
    }

    // A pixel stays open while nothing covers it, or only a triangle with fragments still to come.
    bool isOpen(int x, int y) {
        uint32_t id = mFrame.targets.id.at(x, y);
        if (id == 0) return true;
        if (mSlot.drawn.empty()) return false;
        const DrawnTriangle* d = findDrawn(id - 1);
        return d && d->fragmentsLeft > 0;
    }

    // Removes the closed pixels from the open segments, splitting segments where needed.
    void shrink() {
        mSlot.next.clear();
        mOpen = 0;
        for (const PixelSpan& p : mSlot.spans) {
            int start = -1;
            for (int x = p.x0; x <= p.x1 + 1; ++x) {
                bool open = x <= p.x1 && isOpen(x, p.y);
                if (open && start < 0) start = x;
                if (!open && start >= 0) {
                    mSlot.next.push_back({p.y, start, x - 1});
                    mOpen += x - start;
                    start = -1;
                }
            }
        }
        std::swap(mSlot.spans, mSlot.next);
    }

    scene::PixelRect openRect() const {
        scene::PixelRect r{std::numeric_limits<int>::max(), std::numeric_limits<int>::max(),
                           std::numeric_limits<int>::min(), std::numeric_limits<int>::min()};
        for (const PixelSpan& p : mSlot.spans) {
            r.x0 = std::min(r.x0, p.x0);
            r.x1 = std::max(r.x1, p.x1 + 1);
            r.y0 = std::min(r.y0, p.y);
            r.y1 = std::max(r.y1, p.y + 1);
        }
        return r;
    }

    // Counts the pixels of `searched` (the piece's pixels the expansion left open) as drawn or
    // empty, gives the empty ones the clear colour (depth and ID are already 0) and, where the
    // frame keeps hole classes, writes every pixel's PixelSource: the rest of the piece's pixels
    // (when `expanded`) were drawn from the expansion polygon.
    void classify(std::span<const PixelSpan> piece, std::span<const PixelSpan> searched,
                  bool expanded) {
        const bool classes = mFrame.holeClass.data != nullptr;
        if (classes && expanded)
            for (const PixelSpan& p : piece)
                std::fill_n(mFrame.holeClass.row(p.y) + p.x0, p.x1 - p.x0 + 1,
                            uint8_t(PixelSource::kExpansion));
        // Row pointers and counts in locals: the class bytes' stores could alias the frame's
        // views and the stats, which the compiler would then reload for every pixel.
        const Rgba8 clear = mFrame.options.render.clearColor;
        int64_t disoccluded = 0, empty = 0;
        for (const PixelSpan& p : searched) {
            const uint32_t* id = mFrame.targets.id.row(p.y);
            Rgba8* color = mFrame.second.color.row(p.y);
            uint8_t* cls = classes ? mFrame.holeClass.row(p.y) : nullptr;
            for (int x = p.x0; x <= p.x1; ++x) {
                const bool drawn = id[x] != 0;
                if (drawn) {
                    ++disoccluded;
                } else {
                    color[x] = clear;
                    ++empty;
                }
                if (cls)
                    cls[x] = uint8_t(drawn ? PixelSource::kDisocclusion
                                           : PixelSource::kDisocclusionEmpty);
            }
        }
        mSlot.stats.disocclusionPixels += disoccluded;
        mSlot.stats.emptyPixels += empty;
    }

    const FillFrame& mFrame;
    FillScratch::Slot& mSlot;
    int64_t mOpen = 0;
    const Hole* mFrontOf = nullptr;  // the hole mFrontInvW belongs to
    float mFrontInvW = 0.0f;
};

void addStats(const FillStats& a, FillStats* sum) {
    sum->expansionPixels += a.expansionPixels;
    sum->disocclusionPixels += a.disocclusionPixels;
    sum->emptyPixels += a.emptyPixels;
    sum->nodesVisited += a.nodesVisited;
    sum->boxNodesTested += a.boxNodesTested;
    sum->polygonsTested += a.polygonsTested;
    sum->polygonsDrawn += a.polygonsDrawn;
    sum->rayPieces += a.rayPieces;
}

// The pieces of a hole larger than a tile: its segments cut at tile columns and grouped by tile,
// tile rows in order (the segments come in row order), each tile row's cuts placed by tile column
// with a counting sort, which keeps them in row order within a tile.
void cutIntoTiles(const HoleSet& holes, uint32_t h, HolePieces* out) {
    const Hole& hole = holes.holes[h];
    const int firstColumn = hole.box.x0 / kFillTile;
    const size_t columns = size_t(hole.box.x1 / kFillTile - firstColumn + 1);
    const int32_t end = hole.firstSegment + hole.segmentCount;
    for (int32_t i = hole.firstSegment; i < end;) {
        const int tileRow = holes.segments[size_t(i)].y / kFillTile;
        out->tiled.clear();
        for (; i < end && holes.segments[size_t(i)].y / kFillTile == tileRow; ++i) {
            const HoleSegment& seg = holes.segments[size_t(i)];
            for (int x0 = seg.xStart; x0 <= seg.xEnd;) {
                const int x1 = std::min(seg.xEnd, (x0 / kFillTile + 1) * kFillTile - 1);
                out->tiled.push_back({uint32_t(x0 / kFillTile - firstColumn), {seg.y, x0, x1}});
                x0 = x1 + 1;
            }
        }
        std::vector<uint32_t>& start = out->columnStart;
        start.assign(columns + 1, 0);
        for (const auto& [column, span] : out->tiled) ++start[column + 1];
        for (size_t c = 0; c < columns; ++c) start[c + 1] += start[c];
        const uint32_t base = uint32_t(out->spans.size());
        const size_t firstPiece = out->pieces.size();
        for (size_t c = 0; c < columns; ++c)
            if (start[c + 1] > start[c])
                out->pieces.push_back({base + start[c], start[c + 1] - start[c], 0});
        out->spans.resize(base + out->tiled.size());
        for (const auto& [column, span] : out->tiled) out->spans[base + start[column]++] = span;
        for (size_t p = firstPiece; p < out->pieces.size(); ++p) {
            FillPiece& piece = out->pieces[p];
            for (uint32_t k = piece.firstSpan; k < piece.firstSpan + piece.spanCount; ++k)
                piece.pixels += out->spans[k].x1 - out->spans[k].x0 + 1;
        }
    }
}

// Cuts hole h into pieces, in place of out's: one for a hole whose box fits in a kFillTile square
// (box nodes tested 45.8k -> 43.2k on office:280 against cutting those at tile boundaries too),
// else one per kFillTile tile it touches.
void cutIntoPieces(const HoleSet& holes, uint32_t h, HolePieces* out) {
    out->spans.clear();
    out->pieces.clear();
    const Hole& hole = holes.holes[h];
    if (hole.box.x1 - hole.box.x0 >= kFillTile || hole.box.y1 - hole.box.y0 >= kFillTile) {
        cutIntoTiles(holes, h, out);
        return;
    }
    const int32_t first = hole.firstSegment, end = first + hole.segmentCount;
    out->pieces.push_back({0, uint32_t(end - first), hole.pixelCount});
    for (int32_t i = first; i < end; ++i) {
        const HoleSegment& seg = holes.segments[size_t(i)];
        out->spans.push_back({seg.y, seg.xStart, seg.xEnd});
    }
}

// Counts the pixels of the expansion holes that fillExpansionHoles filled and, where the frame
// keeps hole classes, marks them.
int64_t markInterpolated(const HoleSet& holes, ImageView<uint8_t> holeClass) {
    int64_t pixels = 0;
    for (const Hole& hole : holes.holes) {
        if (hole.holeClass != HoleClass::kExpansion) continue;
        pixels += hole.pixelCount;
        if (!holeClass.data) continue;
        for (int32_t i = hole.firstSegment; i < hole.firstSegment + hole.segmentCount; ++i) {
            const HoleSegment& seg = holes.segments[size_t(i)];
            for (int x = seg.xStart; x <= seg.xEnd; ++x)
                holeClass.at(x, seg.y) = uint8_t(PixelSource::kExpansion);
        }
    }
    return pixels;
}

}  // namespace

FillStats fillHoles(const scene::Scene& scene, const FillScene& fill, const Camera& camera,
                    const FillOptions& options, const HoleSet& holes,
                    const SecondEyeTargets& second, ImageView<uint8_t> holeClass,
                    FillScratch* scratch, ThreadPool* pool) {
    PLX_CHECK(second.id.width == camera.width() && second.id.height == camera.height());
    PLX_CHECK(!holeClass.data ||
              (holeClass.width == camera.width() && holeClass.height == camera.height()));
    PLX_CHECK(enumWithin(options.search, FillSearch::kBoxHierarchy, FillSearch::kBspOrder) &&
              enumWithin(options.expansion, ExpansionFill::kEvaluate, ExpansionFill::kInterpolate));
    PLX_CHECK(fill.serves(options.search));
    PLX_CHECK(!fill.bspBuilt || fill.fragmentsOfTriangle.size() == scene.triangleCount());
    FillStats total;
    const bool interpolate = options.expansion == ExpansionFill::kInterpolate;
    if (interpolate) {
        fillExpansionHoles(holes, second);
        total.expansionPixels = markInterpolated(holes, holeClass);
    }
    FillOptions drawOptions = options;
    drawOptions.render.colorOnly = false;
    FillFrame frame{scene,
                    fill,
                    camera,
                    drawOptions,
                    second,
                    holes,
                    {second.color, second.depth, second.id, {}},
                    holeClass};
    const size_t slots = pool ? size_t(pool->threadCount()) : 1;
    while (scratch->mSlots.size() < slots)
        scratch->mSlots.push_back(std::make_unique<FillScratch::Slot>());
    for (auto& slot : scratch->mSlots) slot->stats = {};
    // Each hole cut into pieces by the thread that fills it, so no thread waits for the cuts.
    auto body = [&](size_t begin, size_t end) {
        FillScratch::Slot& slot = *scratch->mSlots[size_t(currentThreadSlot()) % slots];
        HolePieces& cut = slot.pieces;
        HoleFiller filler(frame, slot);
        for (size_t h = begin; h < end; ++h) {
            if (interpolate && holes.holes[h].holeClass == HoleClass::kExpansion) continue;
            cutIntoPieces(holes, uint32_t(h), &cut);
            for (const FillPiece& piece : cut.pieces)
                filler.fill(
                    holes.holes[h],
                    std::span<const PixelSpan>(cut.spans).subspan(piece.firstSpan, piece.spanCount),
                    piece.pixels);
        }
    };
    // Holes differ in cost by orders of magnitude (a one-pixel crack, the strip at the image
    // border): single holes let the threads balance.
    constexpr size_t kHoleGrain = 1;
    if (pool)
        pool->parallelFor(holes.holes.size(), kHoleGrain, body);
    else
        body(0, holes.holes.size());
    for (auto& slot : scratch->mSlots) addStats(slot->stats, &total);
    return total;
}

}  // namespace plx::stereo
