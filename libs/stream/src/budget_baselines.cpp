// The two baselines of the allocation comparison (docs/stream-results.md), beside the paper's
// ACH rule (budget.cpp): an equal split of the budget among the textures in view, whatever their
// cells' coverage hints, and an LRU texture cache over mipmap levels that loads on demand and
// evicts the least recently seen textures first.
#include <plx/stream/budget.h>

#include <algorithm>

namespace plx::stream {
namespace {

// The distinct, not failed nodes of the cells, ascending.
std::vector<int> nodesOfCells(const std::vector<VisibleCell>& cells,
                              const std::vector<PtmNode>& nodes) {
    std::vector<int> ids;
    for (const VisibleCell& c : cells)
        for (int n : c.nodes)
            if (!nodes[size_t(n)].failed) ids.push_back(n);
    std::sort(ids.begin(), ids.end());
    ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
    return ids;
}

// The most levels, at most `most`, whose chain fits in `bytes`.
int levelsWithin(const PtmNode& node, uint64_t bytes, int most) {
    int k = std::min(most, node.total());
    while (k > 0 && node.chainBytes(k) > bytes) --k;
    return k;
}

}  // namespace

uint64_t allocateEqualSplit(const std::vector<VisibleCell>& cells, uint64_t budget,
                            std::vector<PtmNode>& nodes) {
    std::vector<int> ids = nodesOfCells(cells, nodes);
    auto whole = [&](int n) { return nodes[size_t(n)].chainBytes(nodes[size_t(n)].total()); };
    // Water-filling: the smallest whole chains first, each node taking the equal share of what
    // is left or less when its whole chain needs less.
    std::stable_sort(ids.begin(), ids.end(), [&](int a, int b) { return whole(a) < whole(b); });
    uint64_t left = budget;
    std::vector<uint64_t> share(ids.size());
    for (size_t i = 0; i < ids.size(); ++i) {
        share[i] = std::min(left / (ids.size() - i), whole(ids[i]));
        left -= share[i];
    }
    // A share buys whole levels only (refreshResident adds a level when its chain fits).
    left = budget;
    for (size_t i = 0; i < ids.size(); ++i) {
        PtmNode& node = nodes[size_t(ids[i])];
        node.saved = node.chainBytes(levelsWithin(node, share[i], node.total()));
        left -= node.saved;
    }
    // What rounding freed: one more level each, the smallest next level first.
    auto next = [&](int n) {
        const PtmNode& node = nodes[size_t(n)];
        const int k = levelsWithin(node, node.saved, node.total());
        return k < node.total() ? node.levelBytes[size_t(k)] : UINT64_MAX;
    };
    std::stable_sort(ids.begin(), ids.end(), [&](int a, int b) { return next(a) < next(b); });
    for (int n : ids) {
        const uint64_t bytes = next(n);
        if (bytes > left) break;
        nodes[size_t(n)].saved += bytes;
        left -= bytes;
    }
    return budget - left;
}

uint64_t allocateLru(const std::vector<VisibleCell>& cells, uint64_t budget,
                     std::vector<PtmNode>& nodes, double nowS) {
    const std::vector<int> seen = nodesOfCells(cells, nodes);
    uint64_t left = budget;
    // A node keeps as many of its resident levels as the budget left holds.
    auto keep = [&](PtmNode& node) {
        node.saved = node.chainBytes(levelsWithin(node, left, node.resident));
        left -= node.saved;
    };
    // The working set: what the nodes in view hold stays (hits).
    for (int n : seen) {
        nodes[size_t(n)].lastSeenS = nowS;
        keep(nodes[size_t(n)]);
    }
    // Misses: the next level of each node in view, in node order, while the budget holds it.
    for (int n : seen) {
        PtmNode& node = nodes[size_t(n)];
        if (node.resident >= node.total() || node.saved != node.residentBytes()) continue;
        const uint64_t bytes = node.levelBytes[size_t(node.resident)];
        if (bytes > left) continue;
        node.saved += bytes;
        left -= bytes;
    }
    // The rest of the cache, most recently seen first: the least recently seen are evicted.
    std::vector<int> others;
    for (size_t n = 0; n < nodes.size(); ++n)
        if (nodes[n].resident > 0 && !nodes[n].failed && nodes[n].lastSeenS < nowS)
            others.push_back(int(n));
    std::stable_sort(others.begin(), others.end(), [&](int a, int b) {
        return nodes[size_t(a)].lastSeenS > nodes[size_t(b)].lastSeenS;
    });
    for (int n : others) keep(nodes[size_t(n)]);
    return budget - left;
}

}  // namespace plx::stream
