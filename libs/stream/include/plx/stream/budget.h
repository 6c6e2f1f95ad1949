#pragma once
// Memory budget allocation and PTM node updates (Marvie & Bouatouch 6.1 and 6.2), as pure
// functions over PTM nodes so that scripted budgets can test them.
//
// Level numbering: a node's levels are numbered as the PTM file stores them, 0 = the smallest.
// `resident` levels 0..resident-1 are in (graphics) memory, so the paper's L (current highest
// level) is resident - 1; `downloaded` levels 0..downloaded-1 have arrived, so L_max is
// downloaded - 1; L_total is the file's level count. S(L) is the memory of the mipmap chain up
// to level L: the texel bytes of levels 0..L (a texture needs its smaller levels too).

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include <plx/core/status.h>

namespace plx::stream {

struct PtmNode {
    std::string url;
    uint64_t fileBytes = 0;            // as the cell file states it
    std::vector<uint64_t> levelBytes;  // texel bytes per level; empty until the header arrived
    std::vector<uint64_t> groupBytes;  // download bytes per level group
    int resident = 0;                  // levels resident (L + 1)
    int downloaded = 0;                // levels downloaded (L_max + 1)
    bool downloading = false;          // a level request is queued or on the link
    bool failed = false;               // skipped after its retries: never offered budget
    uint64_t saved = 0;                // N: budget kept during this frame's computeVS calls
    // When a visible cell last held the node (simulated seconds); -infinity: never. Only the
    // LRU policy reads it.
    double lastSeenS = -std::numeric_limits<double>::infinity();

    int total() const { return int(levelBytes.size()); }
    // S: bytes of the chain of the first `levels` levels (levels 0..levels-1).
    uint64_t chainBytes(int levels) const;
    uint64_t residentBytes() const { return chainBytes(resident); }
};

// Marvie 6.2, computeVS: the node keeps the offered `alloc` while even N + alloc cannot hold
// level L+1 (it saves up), else keeps only what S(L+1) needs and returns the rest; without a
// level L+1 the same test uses L. Returns the bytes kept (added to node.saved).
uint64_t offerBudget(PtmNode& node, uint64_t alloc);

enum class RefreshAction { kNone, kAdd, kRemove, kDownload };

// Marvie 6.2, refreshResident, in the paper's order with N = node.saved:
//   S(L+1) <= N, L+1 <= L_max, L+1 < L_total   -> add level L+1 (only when its bytes fit in
//                                                 freeBytes: the client's hard cap);
//   else S(L) > N                               -> remove level L;
//   else not downloading, S(L+1) <= N, L+1 > L_max, L+1 < L_total
//                                               -> download level L+1 when allowDownload(its
//                                                  group bytes) (the dt_max rule).
// The paper's "L+1 <= L_total" and "L+1 != L_total" count levels from 1; here both read "level
// L+1 exists". Updates node.resident / node.downloading.
RefreshAction refreshResident(PtmNode& node, uint64_t freeBytes,
                              const std::function<bool(uint64_t)>& allowDownload);

// A visible cell of this frame: its ACH in the current cell's PVS and its PTM nodes.
struct VisibleCell {
    int cell = 0;
    double ach = 0.0;
    std::vector<int> nodes;
    // Beyond the paper: each node's texture coverage hint from the current cell (the pixels of
    // the current cell's sampling that show the texture, over all its pixels), parallel to
    // `nodes`; empty when the database has no hints.
    std::vector<double> coverage{};
};

// Marvie 6.1: the cells share out `budget` from the highest ACH to the lowest. Each cell gets
// its normalised ACH (over the cells not yet served) of what the previous cells left, offers it
// to its nodes in turn (each an equal part of what is left of the cell's share) and returns
// what they kept; the next cell shares out M - M_used. Nodes' `saved` must be reset before.
// Returns M_used over all cells (<= budget).
uint64_t allocateBudget(std::vector<VisibleCell> cells, uint64_t budget,
                        std::vector<PtmNode>& nodes);

// Beyond the paper: 6.1's split by normalised ACH, from the highest cell to the lowest, but a
// node keeps of N + alloc only the chain of whole levels it buys (at most S(L+1), S(L) at the
// top level) and returns the remainder, which goes to the next nodes of its cell and the next
// cells; what the last cell leaves is offered once more to the nodes in ACH order, each keeping
// its next level when it fits. The paper's 6.2 computeVS (offerBudget) instead keeps the whole
// offer while N + alloc < S(L+1) ("saving up"), so a share that buys no level sits idle for the
// frame (docs/stream-results.md). Nodes' `saved` must be reset before. Returns the bytes kept
// (<= budget), all of them usable: each node's `saved` is a chain of whole levels.
uint64_t allocateAchReturning(std::vector<VisibleCell> cells, uint64_t budget,
                              std::vector<PtmNode>& nodes);

// Beyond the paper: 6.1's rule with textures in place of cells. First a floor: every distinct
// node of `cells` is offered a quarter of an equal share (so a texture the sampling missed still
// gets its coarse levels). Then the nodes share what is left from the highest texture coverage
// hint to the lowest, each its normalised hint
// (over the nodes not yet served) of what is left; a node keeps of it the chain of whole levels
// it buys (at most S(L+1)) and the rest goes on; what the last node leaves is offered once more
// in the same order, each keeping its next level when it fits. Where no node has a hint, this is
// allocateAchReturning. Nodes' `saved` must be reset before. Returns the bytes kept (<= budget).
uint64_t allocateByTextureCoverage(std::vector<VisibleCell> cells, uint64_t budget,
                                   std::vector<PtmNode>& nodes);

// How the client shares the memory budget among the PTM nodes of the visible cells each frame,
// by setting every node's `saved` (N) before refreshResident. A closed set: the paper's rule, a
// variant of it that passes unusable shares on, and two baselines for the comparison of
// section 7 (docs/stream-results.md). Every policy hands out at most the budget (the sum of the
// nodes' `saved` stays <= budget).
enum class AllocationPolicy {
    kAch,  // Marvie 6.1 and 6.2: cells by normalised ACH, nodes keep or return (allocateBudget)
    kAchReturn,  // 6.1's split, unusable remainders go on (allocateAchReturning; not the paper)
    kAchTexture,  // 6.1's split over textures by coverage hints (allocateByTextureCoverage)
    kLru,  // a texture cache: next levels on demand, least recently seen evicted (allocateLru)
    kEqualSplit,  // every texture in view gets the same share (allocateEqualSplit)
};

// "ach", "ach-return", "ach-texture", "lru", "equal".
std::string_view policyName(AllocationPolicy policy);
// The inverse of policyName. Errors: any other text (the message lists the names).
Result<AllocationPolicy> parsePolicy(std::string_view name);

// Equal split: the distinct nodes of `cells` (failed ones excepted) share `budget` equally; a
// node whose whole chain needs less than its share keeps only that and the rest is shared again
// among the others (water-filling, smallest chains first). A share is then rounded down to the
// chain of whole levels it holds, and what rounding frees goes once more to the nodes, smallest
// next level first, one level each while it fits. Nodes outside `cells` get nothing. Nodes'
// `saved` must be reset before. Returns the bytes handed out (<= budget).
uint64_t allocateEqualSplit(const std::vector<VisibleCell>& cells, uint64_t budget,
                            std::vector<PtmNode>& nodes);

// LRU: a texture cache over mipmap levels. The nodes of `cells` are seen at nowS; each keeps its
// resident chain, then asks for its next level (a miss), served in node order (the order the
// nodes were registered, which is the drawing order) while the budget left holds it; nodes not
// seen this frame keep their levels with what is left after that, the most recently seen first,
// so the least recently seen lose theirs first (top level first). A node seen this frame is
// never evicted for another one seen this frame (no thrashing). Nodes' `saved` must be reset
// before. Returns the bytes handed out (<= budget).
uint64_t allocateLru(const std::vector<VisibleCell>& cells, uint64_t budget,
                     std::vector<PtmNode>& nodes, double nowS);

// The policy's allocation (one of the five above).
uint64_t allocate(AllocationPolicy policy, std::vector<VisibleCell> cells, uint64_t budget,
                  std::vector<PtmNode>& nodes, double nowS);

}  // namespace plx::stream
