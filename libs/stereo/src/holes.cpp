#include <algorithm>
#include <array>
#include <cmath>

#include <plx/core/check.h>
#include <plx/stereo/holes.h>

#include "byte_runs.h"

namespace plx::stereo {

namespace {

int32_t findRoot(std::vector<int32_t>& parent, int32_t h) {
    int32_t root = h;
    while (parent[size_t(root)] != root) root = parent[size_t(root)];
    while (parent[size_t(h)] != root) {  // path compression
        int32_t up = parent[size_t(h)];
        parent[size_t(h)] = root;
        h = up;
    }
    return root;
}

// Appends row y's segments, left to right, from the mask (Fu Fig. 5).
void appendMaskRow(ImageView<const uint8_t> holeMask, int y, std::vector<HoleSegment>& segs) {
    forEachNonZeroRun(holeMask.row(y), holeMask.width, [&](int x0, int end) {
        segs.push_back({x0, end - 1, end - x0, y, -1});
    });
}

// Joins each of the current row's segments [curBegin, curEnd) to the holes of the previous row's
// segments [prevBegin, prevEnd) it touches (`slack` columns apart at most); the two rows'
// segments are both in column order, so one forward sweep finds every pair.
void joinRow(HoleScratch& scratch, size_t prevBegin, size_t prevEnd, size_t curBegin, size_t curEnd,
             int32_t slack) {
    const std::vector<HoleSegment>& segs = scratch.rowSegments;
    std::vector<int32_t>& label = scratch.label;
    std::vector<int32_t>& parent = scratch.parent;
    size_t j = prevBegin;
    for (size_t c = curBegin; c < curEnd; ++c) {
        const HoleSegment& cs = segs[c];
        while (j < prevEnd && segs[j].xEnd + slack < cs.xStart) ++j;
        int32_t hole = -1;
        for (size_t p = j; p < prevEnd && segs[p].xStart <= cs.xEnd + slack; ++p) {
            int32_t other = findRoot(parent, label[p]);
            if (hole < 0) {
                hole = other;
            } else if (other != hole) {
                // The segment bridges two holes (the bottom of a U): merge them, keeping the
                // older root so labels stay stable.
                int32_t keep = std::min(hole, other), gone = std::max(hole, other);
                parent[size_t(gone)] = keep;
                hole = keep;
            }
        }
        if (hole < 0) {
            hole = int32_t(parent.size());
            parent.push_back(hole);
        }
        label[c] = hole;
    }
}

// Holes in the order of their first segment (scan order); each hole's segments placed
// contiguously with a stable counting sort, so they stay in scan order.
//
// Provisional holes are numbered in the scan order of the segment that opened each, and every
// merge (joinRow) and path compression (findRoot) points a hole at a smaller number, so
// parent[i] <= i: one forward pass gives every provisional hole its final index, the roots
// numbered in the order of their first segments, without a root search per segment.
void compactHoles(HoleScratch& scratch, HoleSet& out) {
    const std::vector<HoleSegment>& segs = scratch.rowSegments;
    const std::vector<int32_t>& parent = scratch.parent;
    std::vector<int32_t>& finalIndex = scratch.finalIndex;
    finalIndex.resize(parent.size());
    int32_t holeCount = 0;
    for (size_t i = 0; i < parent.size(); ++i) {
        PLX_DCHECK(parent[i] <= int32_t(i));
        finalIndex[i] = parent[i] == int32_t(i) ? holeCount++ : finalIndex[size_t(parent[i])];
    }
    out.holes.assign(size_t(holeCount), Hole{});
    out.pixelCount = 0;
    std::vector<int32_t>& label = scratch.label;
    for (size_t s = 0; s < segs.size(); ++s) {
        const int32_t index = finalIndex[size_t(label[s])];
        label[s] = index;
        Hole& h = out.holes[size_t(index)];
        const HoleSegment& seg = segs[s];
        if (h.segmentCount == 0) h.box = {seg.xStart, seg.y, seg.xEnd, seg.y};
        h.segmentCount += 1;
        h.pixelCount += seg.count;
        h.box.x0 = std::min(h.box.x0, seg.xStart);
        h.box.x1 = std::max(h.box.x1, seg.xEnd);
        h.box.y1 = seg.y;  // segments come in row order
        out.pixelCount += seg.count;
    }
    std::vector<int32_t>& cursor = scratch.cursor;
    cursor.resize(out.holes.size());
    int32_t first = 0;
    for (size_t h = 0; h < out.holes.size(); ++h) {
        out.holes[h].firstSegment = first;
        cursor[h] = first;
        first += out.holes[h].segmentCount;
    }
    out.segments.resize(segs.size());
    for (size_t s = 0; s < segs.size(); ++s) {
        const Hole& h = out.holes[size_t(label[s])];
        const int32_t slot = cursor[size_t(label[s])]++;
        HoleSegment& placed = out.segments[size_t(slot)];
        placed = segs[s];
        placed.next = slot + 1 < h.firstSegment + h.segmentCount ? slot + 1 : -1;
    }
}

// findHoles over `height` rows whose segments appendRow(y, segments) appends in column order.
template <class AppendRow>
void mergeRows(int height, HoleConnectivity connectivity, HoleScratch& scratch, HoleSet& out,
               const AppendRow& appendRow) {
    scratch.rowSegments.clear();
    scratch.label.clear();
    scratch.parent.clear();
    // Diagonal neighbours count as touching for 8-connectivity: ranges may be one column apart.
    const int32_t slack = connectivity == HoleConnectivity::k8 ? 1 : 0;
    size_t prevBegin = 0, prevEnd = 0;
    for (int y = 0; y < height; ++y) {
        const size_t curBegin = scratch.rowSegments.size();
        appendRow(y, scratch.rowSegments);
        const size_t curEnd = scratch.rowSegments.size();
        scratch.label.resize(curEnd, -1);
        joinRow(scratch, prevBegin, prevEnd, curBegin, curEnd, slack);
        prevBegin = curBegin;
        prevEnd = curEnd;
    }
    compactHoles(scratch, out);
}

}  // namespace

void findHoles(ImageView<const uint8_t> holeMask, HoleConnectivity connectivity,
               HoleScratch& scratch, HoleSet& out) {
    mergeRows(holeMask.height, connectivity, scratch, out,
              [&](int y, std::vector<HoleSegment>& segs) { appendMaskRow(holeMask, y, segs); });
}

void findHoles(const HoleRuns& runs, HoleConnectivity connectivity, HoleScratch& scratch,
               HoleSet& out) {
    mergeRows(int(runs.rows.size()), connectivity, scratch, out,
              [&](int y, std::vector<HoleSegment>& segs) {
                  for (const HoleRun& r : runs.rows[size_t(y)])
                      segs.push_back({r.x0, r.x1, r.x1 - r.x0 + 1, y, -1});
              });
}

namespace {

void classifyHole(ImageView<const uint32_t> id, const std::vector<HoleSegment>& segments,
                  const SameSurface& sameSurface, Hole& h) {
    const int32_t w = id.width;
    // The distinct neighbour IDs; each after the first must be of one surface with one already
    // found.
    std::array<uint32_t, kMaxSurfacePolygons> ids;
    int count = 0;
    auto add = [&](uint32_t neighbour) {
        if (neighbour == 0) return false;  // no polygon to extend
        for (int i = 0; i < count; ++i)
            if (ids[size_t(i)] == neighbour) return true;
        if (count > 0 && (!sameSurface || count == kMaxSurfacePolygons)) return false;
        bool joined = count == 0;
        for (int i = 0; i < count && !joined; ++i) joined = sameSurface(ids[size_t(i)], neighbour);
        if (joined) ids[size_t(count++)] = neighbour;
        return joined;
    };
    bool expansion = true;
    for (int32_t s = h.firstSegment; expansion && s < h.firstSegment + h.segmentCount; ++s) {
        const HoleSegment& seg = segments[size_t(s)];
        PLX_CHECK(seg.y >= 0 && seg.y < id.height && seg.xEnd < w);
        // Image border rule: nothing known beyond the first eye's left or right edge.
        if (seg.xStart == 0 || seg.xEnd == w - 1) {
            expansion = false;
            break;
        }
        const uint32_t* row = id.row(seg.y);
        expansion = add(row[seg.xStart - 1]) && add(row[seg.xEnd + 1]);
    }
    h.holeClass = expansion ? HoleClass::kExpansion : HoleClass::kDisocclusion;
    h.polygonId = expansion ? ids[0] : 0;
    h.polygonCount = expansion ? count : 0;
}

}  // namespace

void classifyHoles(ImageView<const uint32_t> id, HoleSet& holes, const SameSurface& sameSurface,
                   ThreadPool* pool) {
    auto body = [&](size_t begin, size_t end) {
        for (size_t h = begin; h < end; ++h)
            classifyHole(id, holes.segments, sameSurface, holes.holes[h]);
    };
    // Holes differ in size by orders of magnitude; small chunks let the threads balance.
    constexpr size_t kHoleGrain = 16;
    if (pool)
        pool->parallelFor(holes.holes.size(), kHoleGrain, body);
    else
        body(0, holes.holes.size());
}

void fillExpansionHoles(const HoleSet& holes, const SecondEyeTargets& second) {
    for (const Hole& h : holes.holes) {
        if (h.holeClass != HoleClass::kExpansion) continue;
        for (int32_t s = h.firstSegment; s < h.firstSegment + h.segmentCount; ++s) {
            const HoleSegment& seg = holes.segments[size_t(s)];
            PLX_CHECK(seg.xStart > 0 && seg.xEnd + 1 < second.color.width);
            int32_t xl = seg.xStart - 1, xr = seg.xEnd + 1;
            Rgba8* color = second.color.row(seg.y);
            float* depth = second.depth.row(seg.y);
            uint32_t* id = second.id.row(seg.y);
            uint8_t* hole = second.holeMask.data ? second.holeMask.row(seg.y) : nullptr;
            Rgba8 cl = color[xl], cr = color[xr];
            float dl = depth[xl], dr = depth[xr];
            float span = float(xr - xl);
            auto mix = [](uint8_t a, uint8_t b, float t) {
                return uint8_t(std::lround(float(a) + (float(b) - float(a)) * t));
            };
            for (int32_t x = seg.xStart; x <= seg.xEnd; ++x) {
                float t = float(x - xl) / span;
                color[x] = {mix(cl.r, cr.r, t), mix(cl.g, cr.g, t), mix(cl.b, cr.b, t),
                            mix(cl.a, cr.a, t)};
                depth[x] = dl + (dr - dl) * t;
                id[x] = h.polygonCount <= 1 ? h.polygonId : (t < 0.5f ? id[xl] : id[xr]);
                if (hole) hole[x] = 0;
            }
        }
    }
}

}  // namespace plx::stereo
