// Marvie & Bouatouch 6.1 (budget by ACH) and 6.2 (PTM node rules, refreshResident), and the
// variant of 6.1 that returns what a node cannot use for a whole level (allocateAchReturning).
#include <plx/stream/budget.h>

#include <algorithm>

#include <fmt/format.h>

namespace plx::stream {

uint64_t PtmNode::chainBytes(int levels) const {
    uint64_t sum = 0;
    for (int k = 0; k < levels && k < total(); ++k) sum += levelBytes[size_t(k)];
    return sum;
}

uint64_t offerBudget(PtmNode& node, uint64_t alloc) {
    if (node.failed || node.total() == 0) return 0;
    // S(L+1), or S(L) when L is the top level.
    const int chain = std::min(node.resident + 1, node.total());
    const uint64_t need = node.chainBytes(chain);
    uint64_t kept = alloc;
    if (need <= node.saved + alloc) kept = need > node.saved ? need - node.saved : 0;
    node.saved += kept;
    return kept;
}

RefreshAction refreshResident(PtmNode& node, uint64_t freeBytes,
                              const std::function<bool(uint64_t)>& allowDownload) {
    const int next = node.resident;  // the index of level L+1
    const bool nextExists = next < node.total();
    const bool nextFits = nextExists && node.chainBytes(next + 1) <= node.saved;
    if (nextFits && next < node.downloaded) {
        // Hard cap: the level goes in only when the frame's budget has room for it.
        if (node.levelBytes[size_t(next)] > freeBytes) return RefreshAction::kNone;
        ++node.resident;
        return RefreshAction::kAdd;
    }
    if (node.resident > 0 && node.chainBytes(node.resident) > node.saved) {
        --node.resident;
        return RefreshAction::kRemove;
    }
    if (!node.downloading && nextFits && next >= node.downloaded &&
        allowDownload(node.groupBytes[size_t(next)])) {
        node.downloading = true;
        return RefreshAction::kDownload;
    }
    return RefreshAction::kNone;
}

namespace {

// The variant's computeVS (not the paper's): of N + alloc the node keeps only the chain of whole
// levels it buys, at most S(L+1) (S(L) when L is the top level), and returns the remainder.
uint64_t offerWholeLevels(PtmNode& node, uint64_t alloc) {
    if (node.failed || node.total() == 0) return 0;
    int k = std::min(node.resident + 1, node.total());
    while (k > 0 && node.chainBytes(k) > node.saved + alloc) --k;
    const uint64_t chain = node.chainBytes(k);
    const uint64_t kept = chain > node.saved ? chain - node.saved : 0;
    node.saved += kept;
    return kept;
}

// 6.1's split over the cells, each node's offer taken by `offer` (the paper's offerBudget or
// offerWholeLevels); `cells` sorted by ACH. Returns the bytes kept.
template <class Offer>
uint64_t shareByAch(const std::vector<VisibleCell>& cells, uint64_t budget,
                    std::vector<PtmNode>& nodes, Offer offer) {
    double achLeft = 0.0;
    for (const VisibleCell& c : cells) achLeft += std::max(0.0, c.ach);
    uint64_t remaining = budget, used = 0;
    for (size_t i = 0; i < cells.size(); ++i) {
        const VisibleCell& c = cells[i];
        // M_i = normalised ACH_i * (M - M_used); the last cell gets all that is left.
        double ach = std::max(0.0, c.ach);
        uint64_t share = achLeft > 0.0 ? uint64_t(double(remaining) * std::min(1.0, ach / achLeft))
                                       : remaining / (cells.size() - i);
        if (i + 1 == cells.size()) share = remaining;
        achLeft -= ach;
        uint64_t cellLeft = share, cellUsed = 0;
        for (size_t n = 0; n < c.nodes.size(); ++n) {
            uint64_t alloc = cellLeft / (c.nodes.size() - n);
            uint64_t kept = offer(nodes[size_t(c.nodes[n])], alloc);
            cellLeft -= kept;
            cellUsed += kept;
        }
        remaining -= cellUsed;
        used += cellUsed;
    }
    return used;
}

void sortByAch(std::vector<VisibleCell>& cells) {
    std::stable_sort(cells.begin(), cells.end(), [](const VisibleCell& a, const VisibleCell& b) {
        return a.ach != b.ach ? a.ach > b.ach : a.cell < b.cell;
    });
}

}  // namespace

uint64_t allocateBudget(std::vector<VisibleCell> cells, uint64_t budget,
                        std::vector<PtmNode>& nodes) {
    sortByAch(cells);
    return shareByAch(cells, budget, nodes, offerBudget);
}

uint64_t allocateAchReturning(std::vector<VisibleCell> cells, uint64_t budget,
                              std::vector<PtmNode>& nodes) {
    sortByAch(cells);
    // First pass: 6.1 as the paper has it; what a node returns stays in its cell's share for the
    // nodes after it, and what the cell does not use goes on to the next cells (M - M_used).
    uint64_t used = shareByAch(cells, budget, nodes, offerWholeLevels);
    // Second pass: what the last cell left goes to the nodes in ACH order, each offered all of
    // it and keeping its next level when that fits.
    for (const VisibleCell& c : cells)
        for (int n : c.nodes) {
            if (used == budget) return used;
            used += offerWholeLevels(nodes[size_t(n)], budget - used);
        }
    return used;
}

// allocateByTextureCoverage's floor: each node first gets 1/kFloorDivisor of an equal share.
constexpr uint64_t kFloorDivisor = 4;

uint64_t allocateByTextureCoverage(std::vector<VisibleCell> cells, uint64_t budget,
                                   std::vector<PtmNode>& nodes) {
    // Each distinct node once, with its hint; a node of several visible cells (a texture used in
    // several rooms) has the same hint in each.
    std::vector<std::pair<double, int>> byHint;  // (hint, node)
    std::vector<bool> listed(nodes.size(), false);
    double hintLeft = 0.0;
    for (const VisibleCell& c : cells)
        for (size_t k = 0; k < c.nodes.size(); ++k) {
            const int n = c.nodes[k];
            if (listed[size_t(n)] || nodes[size_t(n)].failed) continue;
            listed[size_t(n)] = true;
            const double hint = k < c.coverage.size() ? std::max(0.0, c.coverage[k]) : 0.0;
            byHint.emplace_back(hint, n);
            hintLeft += hint;
        }
    if (!(hintLeft > 0.0)) return allocateAchReturning(std::move(cells), budget, nodes);
    std::stable_sort(byHint.begin(), byHint.end(), [](const auto& a, const auto& b) {
        return a.first != b.first ? a.first > b.first : a.second < b.second;
    });
    // A floor first: every node keeps the whole levels that a quarter of an equal share buys, so
    // that a texture the sampling missed (hint 0: seen through a gap no sample point lined up
    // with) is never drawn without levels while it is in view.
    uint64_t used = 0;
    const uint64_t floorShare = budget / (kFloorDivisor * byHint.size());
    for (const auto& [hint, n] : byHint) used += offerWholeLevels(nodes[size_t(n)], floorShare);
    // M_t = normalised hint_t * (M - M_used), as 6.1 gives a cell its share; the last node gets
    // all that is left.
    for (size_t i = 0; i < byHint.size(); ++i) {
        const auto [hint, n] = byHint[i];
        const uint64_t remaining = budget - used;
        uint64_t share = hintLeft > 0.0
                             ? uint64_t(double(remaining) * std::min(1.0, hint / hintLeft))
                             : remaining / (byHint.size() - i);
        if (i + 1 == byHint.size()) share = remaining;
        hintLeft -= hint;
        used += offerWholeLevels(nodes[size_t(n)], share);
    }
    for (const auto& [hint, n] : byHint) {
        if (used == budget) break;
        used += offerWholeLevels(nodes[size_t(n)], budget - used);
    }
    return used;
}

std::string_view policyName(AllocationPolicy policy) {
    switch (policy) {
        case AllocationPolicy::kAch:
            return "ach";
        case AllocationPolicy::kAchReturn:
            return "ach-return";
        case AllocationPolicy::kAchTexture:
            return "ach-texture";
        case AllocationPolicy::kLru:
            return "lru";
        case AllocationPolicy::kEqualSplit:
            return "equal";
    }
    return "ach";
}

Result<AllocationPolicy> parsePolicy(std::string_view name) {
    for (AllocationPolicy p :
         {AllocationPolicy::kAch, AllocationPolicy::kAchReturn, AllocationPolicy::kAchTexture,
          AllocationPolicy::kLru, AllocationPolicy::kEqualSplit})
        if (policyName(p) == name) return p;
    return errorStatus(ErrorCode::kInvalidArgument,
                       fmt::format("unknown allocation policy '{}' (ach, ach-return, "
                                   "ach-texture, lru or equal)",
                                   name.substr(0, 40)));
}

uint64_t allocate(AllocationPolicy policy, std::vector<VisibleCell> cells, uint64_t budget,
                  std::vector<PtmNode>& nodes, double nowS) {
    switch (policy) {
        case AllocationPolicy::kAch:
            return allocateBudget(std::move(cells), budget, nodes);
        case AllocationPolicy::kAchReturn:
            return allocateAchReturning(std::move(cells), budget, nodes);
        case AllocationPolicy::kAchTexture:
            return allocateByTextureCoverage(std::move(cells), budget, nodes);
        case AllocationPolicy::kLru:
            return allocateLru(cells, budget, nodes, nowS);
        case AllocationPolicy::kEqualSplit:
            return allocateEqualSplit(cells, budget, nodes);
    }
    return 0;
}

}  // namespace plx::stream
