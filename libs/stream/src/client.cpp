// The streaming client's frame (Marvie & Bouatouch section 6): completions, current cell and
// prefetch, budget by ACH (6.1), PTM node rules and refreshResident (6.2) under a hard cap.
#include <plx/stream/client.h>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include <plx/stream/glb_reader.h>

namespace plx::stream {
namespace {

// How far the eye or target must move (metres) to count as motion for the static rule.
constexpr float kMoveEpsilon = 1e-4f;
// Logged reasons kept; later ones are counted but not stored (bounded memory on long walks).
constexpr size_t kMaxLogLines = 256;

// The bytes enough to hold any PTM header: the fixed part and the longest level index.
uint64_t maxHeaderBytes() {
    return ptm::headerBytesFor(ptm::fullChainLength(ptm::kMaxSide, ptm::kMaxSide));
}

// Conservative frustum test of a box: outside only when all eight corners lie beyond one clip
// plane (left, right, bottom, top) or behind the eye.
bool boxInFrustum(const Mat4& clipFromWorld, Vec3 lo, Vec3 hi) {
    int outside[5] = {0, 0, 0, 0, 0};
    for (int i = 0; i < 8; ++i) {
        Vec3 p{(i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z};
        Vec4 c = clipFromWorld * Vec4(p, 1.0f);
        outside[0] += c.x < -c.w;
        outside[1] += c.x > c.w;
        outside[2] += c.y < -c.w;
        outside[3] += c.y > c.w;
        outside[4] += c.w <= 0.0f;
    }
    return std::none_of(outside, outside + 5, [](int n) { return n == 8; });
}

bool contains(const CellFile& c, Vec3 p) {
    return p.x >= c.hullMin.x && p.y >= c.hullMin.y && p.z >= c.hullMin.z && p.x <= c.hullMax.x &&
           p.y <= c.hullMax.y && p.z <= c.hullMax.z;
}

}  // namespace

void BandwidthEstimator::add(uint64_t bytes, double submittedAtS, double finishedAtS) {
    double busy = std::max(0.0, finishedAtS - std::max(submittedAtS, mLastFinishedS));
    mLastFinishedS = std::max(mLastFinishedS, finishedAtS);
    mSamples.push_back({bytes, busy});
    while (int(mSamples.size()) > mWindow) mSamples.pop_front();
}

double BandwidthEstimator::secondsFor(uint64_t bytes) const {
    uint64_t sumBytes = 0;
    double sumS = 0.0;
    for (const Sample& s : mSamples) sumBytes += s.bytes, sumS += s.busyS;
    if (sumS <= 0.0) return 0.0;
    if (sumBytes == 0) return sumS / double(mSamples.size());  // only latency seen so far
    return double(bytes) * sumS / double(sumBytes);
}

StreamClient::StreamClient(Fetcher* fetcher, ClientConfig config)
    : mFetcher(fetcher), mConfig(config), mBandwidth(config.bandwidthWindow) {
    PLX_CHECK(fetcher != nullptr && config.maxInFlight >= 1 && config.bandwidthWindow >= 1 &&
              enumWithin(config.policy, AllocationPolicy::kAch, AllocationPolicy::kEqualSplit));
    enqueue({Kind::kRoot, "root.json", std::nullopt, kMaxRootBytes, 0, 0});
}

void StreamClient::enqueue(Request request) {
    mPending[int(request.kind)].push_back(std::move(request));
}

// Cells and geometry go first (section 7.1: they have priority over mipmap levels); the link
// holds at most maxInFlight requests so that a new cell request never waits behind a long
// queue of texture levels.
void StreamClient::submitPending(double nowS) {
    for (auto& queue : mPending) {
        while (!queue.empty() && int(mInFlight.size()) < mConfig.maxInFlight) {
            Request r = std::move(queue.front());
            queue.pop_front();
            uint64_t id = mNextId++;
            mFetcher->submit({id, r.path, r.range, r.maxBytes}, nowS);
            mInFlight.emplace(id, std::move(r));
        }
    }
}

void StreamClient::takeCompletions(double nowS) {
    for (FetchCompletion& done : mFetcher->poll(nowS)) {
        auto it = mInFlight.find(done.id);
        if (it == mInFlight.end()) continue;  // not ours: ignored
        Request request = std::move(it->second);
        mInFlight.erase(it);
        mDownloaded += done.bytes.size();
        if (done.status) mBandwidth.add(done.bytes.size(), done.submittedAtS, done.finishedAtS);
        handle(request, done, nowS);
    }
}

void StreamClient::retryOrSkip(Request request, const std::string& failure) {
    ++mFailed;
    bool retry = request.attempts < mConfig.maxRetries;
    if (mLog.size() < kMaxLogLines)
        mLog.push_back(failure + (retry ? " (retrying)" : " (skipped)"));
    if (retry) {
        ++request.attempts;
        enqueue(std::move(request));
        return;
    }
    switch (request.kind) {
        case Kind::kRoot: mRootFailed = true; break;
        case Kind::kCell: mCells[size_t(request.target)].failed = true; break;
        case Kind::kGeometry: break;  // the cell's textures still stream
        case Kind::kHeader:
        case Kind::kLevel:
            mNodes[size_t(request.target)].failed = true;
            mNodes[size_t(request.target)].downloading = false;
            break;
    }
}

void StreamClient::handle(Request& request, FetchCompletion& done, double nowS) {
    (void)nowS;
    if (!done.status)  // the fetcher's message names the request
        return retryOrSkip(std::move(request), done.status.message());
    if (Status s = accept(request, done.bytes); !s)
        retryOrSkip(
            std::move(request),
            fmt::format("{}: {}", describeRequest(request.path, request.range), s.message()));
}

int StreamClient::nodeFor(const std::string& url, uint64_t fileBytes) {
    auto [it, added] = mNodeOfUrl.emplace(url, int(mNodes.size()));
    if (!added) return it->second;
    PtmNode node;
    node.url = url;
    node.fileBytes = fileBytes;
    mNodes.push_back(std::move(node));
    mDecoders.emplace_back();
    uint64_t last = std::min(fileBytes, maxHeaderBytes()) - 1;
    enqueue({Kind::kHeader, url, ByteRange{0, last}, last + 1, it->second, 0});
    return it->second;
}

// Checks a completion's bytes for its request and applies them. Any error leaves the client as
// it was before the completion (the caller retries or skips).
Status StreamClient::accept(const Request& r, const std::vector<uint8_t>& bytes) {
    if (r.range && bytes.size() != r.range->size())
        return errorStatus(ErrorCode::kCorruptData,
                           fmt::format("{} bytes for a range of {}", bytes.size(), r.range->size()));
    switch (r.kind) {
        case Kind::kRoot: {
            auto root = parseRoot(bytes);
            if (!root) return root.status();
            mRoot = std::move(root).value();
            mCells.resize(mRoot->cells);
            return Status::ok();
        }
        case Kind::kCell: {
            auto cell = parseCell(bytes);
            if (!cell) return cell.status();
            if (cell->index != uint32_t(r.target))
                return errorStatus(ErrorCode::kCorruptData, "cell file of another index");
            for (const PvsUrlEntry& e : cell->pvs)
                if (auto idx = cellIndexOfUrl(e.url, mRoot->cells); !idx) return idx.status();
            Cell& c = mCells[size_t(r.target)];
            for (const UrlBytes& t : cell->textures) c.nodes.push_back(nodeFor(t.url, t.bytes));
            enqueue({Kind::kGeometry, cell->geometry.url, std::nullopt, cell->geometry.bytes,
                     r.target, 0});
            c.file = std::move(cell).value();
            return Status::ok();
        }
        case Kind::kGeometry: {
            auto prims = parseGlb(bytes);
            if (!prims) return prims.status();
            uint64_t triangles = 0;
            for (const GlbPrimitive& p : *prims) triangles += p.indices.size() / 3;
            if (triangles != mCells[size_t(r.target)].file->triangles)
                return errorStatus(ErrorCode::kCorruptData, "triangle count differs from the cell");
            mCells[size_t(r.target)].geometry = true;
            mCells[size_t(r.target)].primitives = std::move(prims).value();
            return Status::ok();
        }
        case Kind::kHeader: {
            auto decoder = ptm::ProgressiveDecoder::create(bytes);
            if (!decoder) return decoder.status();
            const ptm::Header& h = decoder->header();
            PtmNode& node = mNodes[size_t(r.target)];
            if (h.fileBytes() != node.fileBytes)
                return errorStatus(ErrorCode::kCorruptData, "file size differs from the cell's");
            for (int k = 0; k < h.levelCount; ++k) {
                ptm::LevelSize s = h.levelSize(k);
                node.levelBytes.push_back(uint64_t(s.width) * uint64_t(s.height) *
                                          uint64_t(h.components));
                node.groupBytes.push_back(h.groups[size_t(k)].size);
            }
            mDecoders[size_t(r.target)] = std::move(decoder).value();
            return Status::ok();
        }
        case Kind::kLevel: {
            PtmNode& node = mNodes[size_t(r.target)];
            if (Status s = mDecoders[size_t(r.target)]->addGroup(bytes); !s) return s;
            node.downloaded = mDecoders[size_t(r.target)]->levelsDecoded();
            node.downloading = false;
            return Status::ok();
        }
    }
    return Status::ok();
}

void StreamClient::requestCell(int cell) {
    if (cell < 0 || size_t(cell) >= mCells.size()) return;
    Cell& c = mCells[size_t(cell)];
    if (c.requested) return;
    c.requested = true;
    enqueue({Kind::kCell, cellUrl(uint32_t(cell)), std::nullopt, kMaxCellFileBytes, cell, 0});
}

// The format's rule: the lowest-indexed known cell whose closed box holds the point.
int StreamClient::locate(Vec3 eyePos) const {
    for (size_t i = 0; i < mCells.size(); ++i)
        if (mCells[i].file && contains(*mCells[i].file, eyePos)) return int(i);
    return -1;
}

// Trajectory extrapolation (section 6): the eye's velocity over the last frame carried
// prefetchAheadS ahead; the cell found there has its file and PVS requested before the eye
// enters it. A point in no known cell asks for the current cell's neighbours.
void StreamClient::prefetchAlong(Vec3 eyePos, double nowS) {
    (void)nowS;
    Vec3 ahead = eyePos + mVelocity * float(mConfig.prefetchAheadS);
    int next = locate(ahead);
    const Cell& current = mCells[size_t(mCurrentCell)];
    if (next < 0 && current.file) {
        for (const std::string& url : current.file->adjacent)
            if (auto idx = cellIndexOfUrl(url, mRoot->cells)) requestCell(int(*idx));
        return;
    }
    if (next < 0 || next == mCurrentCell || !mCells[size_t(next)].file) return;
    for (const PvsUrlEntry& e : mCells[size_t(next)].file->pvs)
        if (auto idx = cellIndexOfUrl(e.url, mRoot->cells)) requestCell(int(*idx));
}

// Beyond the paper: every node's texture coverage hint in the current cell's sampling, its
// pixels over all the sampling's pixels (0 for a texture it did not see); empty without hints.
// Rebuilt only when the current cell or the node list changed, not every frame.
const std::vector<double>& StreamClient::coverageHintOfNodes() {
    if (mHintCell == mCurrentCell && mHintNodes == mNodes.size()) return mHintOfNode;
    mHintCell = mCurrentCell;
    mHintNodes = mNodes.size();
    mHintOfNode.clear();
    const CellFile& current = *mCells[size_t(mCurrentCell)].file;
    if (current.textureCoverage.empty() || current.totalPixels == 0) return mHintOfNode;
    mHintOfNode.assign(mNodes.size(), 0.0);
    for (const auto& [texture, pixels] : current.textureCoverage)
        if (auto it = mNodeOfUrl.find(textureUrl(texture)); it != mNodeOfUrl.end())
            mHintOfNode[size_t(it->second)] = double(pixels) / double(current.totalPixels);
    return mHintOfNode;
}

// Section 6.1: the cells of the current cell's PVS whose hulls meet the frustum, plus the
// current cell, with their ACHs; and each node's texture coverage hint from the current cell.
std::vector<VisibleCell> StreamClient::visibleCells(const Camera& camera) {
    std::vector<VisibleCell> out;
    const Cell& current = mCells[size_t(mCurrentCell)];
    if (!current.file) return out;
    const std::vector<double>& hintOfNode = coverageHintOfNodes();
    for (const PvsUrlEntry& e : current.file->pvs) {
        auto idx = cellIndexOfUrl(e.url, mRoot->cells);
        if (!idx) continue;
        const Cell& c = mCells[*idx];
        if (!c.file) continue;
        if (int(*idx) != mCurrentCell &&
            !boxInFrustum(camera.clipFromWorld(), c.file->hullMin, c.file->hullMax))
            continue;
        std::vector<double> hints;
        if (!hintOfNode.empty())
            for (int n : c.nodes) hints.push_back(hintOfNode[size_t(n)]);
        out.push_back({int(*idx), e.ach, c.nodes, std::move(hints)});
    }
    return out;
}

// The hard cap: when the budget dropped (static to moving, or a new cell), levels leave until
// the resident bytes fit; first from nodes holding more than they saved, then the largest.
void StreamClient::enforceCap(uint64_t budget) {
    uint64_t resident = 0;
    for (const PtmNode& n : mNodes) resident += n.residentBytes();
    while (resident > budget) {
        PtmNode* victim = nullptr;
        for (PtmNode& n : mNodes) {
            if (n.resident == 0) continue;
            bool over = n.residentBytes() > n.saved;
            bool victimOver = victim && victim->residentBytes() > victim->saved;
            if (!victim || (over && !victimOver) ||
                (over == victimOver && n.levelBytes[size_t(n.resident - 1)] >
                                           victim->levelBytes[size_t(victim->resident - 1)]))
                victim = &n;
        }
        PLX_CHECK(victim != nullptr);
        resident -= victim->levelBytes[size_t(--victim->resident)];
    }
}

// Progressive downloading quality (section 7.1): over the textures of the current cell's PVS,
// downloaded levels over their level counts. A texture whose header has not arrived counts 0
// levels of the largest level count seen (the paper normalises by the highest number).
double StreamClient::quality() const {
    if (mCurrentCell < 0 || !mCells[size_t(mCurrentCell)].file) return 0.0;
    std::vector<int> seen;
    for (const PvsUrlEntry& e : mCells[size_t(mCurrentCell)].file->pvs)
        if (auto idx = cellIndexOfUrl(e.url, mRoot->cells))
            for (int n : mCells[*idx].nodes) seen.push_back(n);
    std::sort(seen.begin(), seen.end());
    seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
    int most = 0;
    for (int n : seen) most = std::max(most, mNodes[size_t(n)].total());
    uint64_t got = 0, all = 0;
    for (int n : seen) {
        const PtmNode& node = mNodes[size_t(n)];
        got += uint64_t(node.downloaded);
        all += uint64_t(node.total() > 0 ? node.total() : most);
    }
    return all == 0 ? (seen.empty() && !mCells.empty() ? 1.0 : 0.0) : double(got) / double(all);
}

FrameReport StreamClient::frame(const Camera& camera, double nowS) {
    takeCompletions(nowS);
    FrameReport report;
    report.timeS = nowS;
    // Motion: the static rule and the velocity for extrapolation.
    Vec3 eye = camera.eyePos(), target = camera.forwardDir();
    double dt = mLastFrameS < 0.0 ? 0.0 : nowS - mLastFrameS;
    if (mLastFrameS < 0.0 || glm::length(eye - mLastEye) > kMoveEpsilon ||
        glm::length(target - mLastTarget) > kMoveEpsilon)
        mLastMoveS = nowS;
    mVelocity = dt > 0.0 ? (eye - mLastEye) / float(dt) : Vec3(0.0f);
    mLastEye = eye, mLastTarget = target, mLastFrameS = nowS;
    report.isStatic = nowS - mLastMoveS >= mConfig.tStaticS;
    const uint64_t budget = report.isStatic ? mConfig.staticBudgetBytes : mConfig.budgetBytes;
    const double dtMax = report.isStatic ? mConfig.dtMaxStaticS : mConfig.dtMaxS;
    report.budgetBytes = budget;

    if (mRoot) {
        // The current cell: where the eye is, else the root's first viewpoint to start from.
        int here = locate(eye);
        if (here < 0 && mCurrentCell < 0)
            if (auto idx = cellIndexOfUrl(mRoot->viewpoints[0].cellUrl, mRoot->cells))
                here = int(*idx);
        if (here >= 0 && here != mCurrentCell) {
            mCurrentCell = here;
            requestCell(here);
        }
        if (mCurrentCell >= 0) {
            const Cell& current = mCells[size_t(mCurrentCell)];
            if (current.file)
                for (const PvsUrlEntry& e : current.file->pvs)
                    if (auto idx = cellIndexOfUrl(e.url, mRoot->cells)) requestCell(int(*idx));
            prefetchAlong(eye, nowS);
        }
    }

    // 6.1 and 6.2 (or a baseline policy): every node's N is this frame's; nodes outside the
    // visible cells get none, except what the LRU policy lets them keep.
    for (PtmNode& n : mNodes) n.saved = 0;
    if (mCurrentCell >= 0) {
        std::vector<VisibleCell> visible = visibleCells(camera);
        report.visibleCells = int(visible.size());
        allocate(mConfig.policy, std::move(visible), budget, mNodes, nowS);
    }
    enforceCap(budget);
    uint64_t resident = 0;
    for (const PtmNode& n : mNodes) resident += n.residentBytes();
    auto allow = [&](uint64_t bytes) { return mBandwidth.secondsFor(bytes) <= dtMax; };
    for (size_t i = 0; i < mNodes.size(); ++i) {
        PtmNode& n = mNodes[i];
        uint64_t before = n.residentBytes();
        RefreshAction a = refreshResident(n, budget - resident, allow);
        resident = resident - before + n.residentBytes();
        if (a == RefreshAction::kDownload) {
            ptm::ByteRange g = ptm::levelByteRange(mDecoders[i]->header(), n.downloaded);
            enqueue({Kind::kLevel, n.url, ByteRange{g.offset, g.offset + g.size - 1}, g.size,
                     int(i), 0});
        }
    }
    PLX_CHECK(resident <= budget);
    submitPending(nowS);

    report.residentBytes = resident;
    report.downloadedBytes = mDownloaded;
    report.quality = quality();
    report.currentCell = mCurrentCell;
    return report;
}

int StreamClient::residentLevel(const std::string& textureUrl) const {
    auto it = mNodeOfUrl.find(textureUrl);
    return it == mNodeOfUrl.end() ? -1 : mNodes[size_t(it->second)].resident - 1;
}

const ByteImage* StreamClient::residentImage(const std::string& textureUrl) const {
    auto it = mNodeOfUrl.find(textureUrl);
    if (it == mNodeOfUrl.end() || mNodes[size_t(it->second)].resident == 0) return nullptr;
    return &mDecoders[size_t(it->second)]->level(mNodes[size_t(it->second)].resident - 1);
}

}  // namespace plx::stream
