#pragma once
// The texture-streaming client (Marvie & Bouatouch section 6): downloads the root, the cell of
// the viewpoint and its PVS (cells and geometry before any texture level), registers one PTM node
// per texture, and per frame splits the memory budget over the visible cells by ACH (6.1), lets
// every node keep or return its share (6.2), and refreshes the resident levels (refreshResident)
// under a hard cap: resident texture bytes never exceed the frame's budget.

#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <plx/core/camera.h>
#include <plx/ptm/decoder.h>
#include <plx/stream/budget.h>
#include <plx/stream/database.h>
#include <plx/stream/fetch.h>
#include <plx/stream/glb_reader.h>
#include <plx/scene/scene.h>

namespace plx::stream {

struct ClientConfig {
    uint64_t budgetBytes = uint64_t(4) << 20;         // M^mem while moving (paper: 4 MB)
    uint64_t staticBudgetBytes = uint64_t(16) << 20;  // M^mem_static (paper: 16 MB)
    double dtMaxS = 0.5;                              // delta t_max (paper: 0.5 s)
    double dtMaxStaticS = 20.0;                       // delta t_max^static (paper: 20 s)
    double tStaticS = 1.0;        // the viewpoint counts as static after this long unmoved
    double prefetchAheadS = 1.0;  // trajectory extrapolation horizon for the next cell
    int maxRetries = 2;           // a failed request is retried this often, then skipped
    int maxInFlight = 2;          // requests on the link at once: one transferring, one waiting
    int bandwidthWindow = 8;      // K: the estimator looks at the last K completions
    // Who gets the budget: the paper's ACH rule, or a baseline for the comparison of section 7.
    AllocationPolicy policy = AllocationPolicy::kAch;
};

// One frame's figures.
struct FrameReport {
    double timeS = 0.0;
    uint64_t budgetBytes = 0;      // the frame's M^mem (moving or static)
    uint64_t residentBytes = 0;    // texel bytes of every resident level, <= budgetBytes
    uint64_t downloadedBytes = 0;  // bodies received so far, every request kind
    double quality = 0.0;          // progressive downloading quality (section 7.1), 0..1
    bool isStatic = false;
    int currentCell = -1;          // -1 until the first cell is known
    int visibleCells = 0;
};

// The link's throughput from recent downloads: bytes over busy time of the last K completions,
// where a completion's busy time runs from max(its submission, the previous completion) to its
// end, so queueing behind another request is not counted. Latency is part of busy time: small
// requests see a lower throughput, as they do on a real link.
class BandwidthEstimator {
public:
    explicit BandwidthEstimator(int window) : mWindow(window) {}
    void add(uint64_t bytes, double submittedAtS, double finishedAtS);
    // Estimated seconds to download `bytes`; 0 before any completion (optimistic: the first
    // request is always sent) or when the link took no time at all.
    double secondsFor(uint64_t bytes) const;

private:
    struct Sample {
        uint64_t bytes;
        double busyS;
    };
    int mWindow;
    std::deque<Sample> mSamples;
    double mLastFinishedS = 0.0;
};

class StreamClient {
public:
    // Preconditions: fetcher outlives the client; checked (abort): fetcher not null,
    // config.maxInFlight and config.bandwidthWindow >= 1, config.policy among its enumerators.
    StreamClient(Fetcher* fetcher, ClientConfig config);

    // One frame at time nowS (non-decreasing) with this camera: takes completions, picks the
    // current cell, allocates the budget, refreshes resident levels, submits requests.
    FrameReport frame(const Camera& camera, double nowS);

    // The highest resident level of a texture URL's node, -1 when none (draw its grey).
    int residentLevel(const std::string& textureUrl) const;
    // The resident image of a texture (its highest resident level), or null.
    const ByteImage* residentImage(const std::string& textureUrl) const;
    // The geometry of the current cell's PVS as downloaded so far, for the renderer: textured
    // materials carry their highest resident level (with a mip chain built below it); a texture
    // with no level resident draws in flat grey (0.5 linear), as does its surface until then.
    // With `fullTextures` (URL -> texture with its mip chain), every texture it names draws from
    // there instead of its resident level: the same geometry at full texture resolution, the
    // reference frames of the allocation comparison. Errors: no geometry yet.
    Result<scene::Scene> residentScene(
        const std::map<std::string, scene::Texture>* fullTextures = nullptr);
    // Hostile or failed completions, each logged with its reason.
    uint64_t failedRequests() const { return mFailed; }
    const std::vector<std::string>& log() const { return mLog; }
    bool rootFailed() const { return mRootFailed; }

private:
    enum class Kind { kRoot, kCell, kGeometry, kHeader, kLevel };
    struct Request {
        Kind kind;
        std::string path;
        std::optional<ByteRange> range;
        uint64_t maxBytes = 0;
        int target = 0;  // cell index, or node index
        int attempts = 0;
    };
    struct Cell {
        std::optional<CellFile> file;
        bool requested = false, failed = false, geometry = false;
        std::vector<int> nodes;  // PTM nodes of the textures its geometry uses
        std::vector<GlbPrimitive> primitives;
    };
    struct CachedTexture {
        int resident = 0;  // the node's resident level count it was built from
        scene::Texture texture;
    };

    void enqueue(Request request);
    void submitPending(double nowS);
    void takeCompletions(double nowS);
    void handle(Request& request, FetchCompletion& done, double nowS);
    Status accept(const Request& request, const std::vector<uint8_t>& bytes);
    void retryOrSkip(Request request, const std::string& failure);  // names the request
    void requestCell(int cell);
    int nodeFor(const std::string& url, uint64_t fileBytes);
    int locate(Vec3 eyePos) const;
    void prefetchAlong(Vec3 eyePos, double nowS);
    std::vector<VisibleCell> visibleCells(const Camera& camera);
    const std::vector<double>& coverageHintOfNodes();
    void enforceCap(uint64_t budget);
    double quality() const;

    Fetcher* mFetcher;
    ClientConfig mConfig;
    BandwidthEstimator mBandwidth;
    std::optional<RootFile> mRoot;
    bool mRootFailed = false;
    std::vector<Cell> mCells;
    std::vector<PtmNode> mNodes;
    std::map<std::string, int> mNodeOfUrl;
    std::vector<std::optional<ptm::ProgressiveDecoder>> mDecoders;  // per node
    std::deque<Request> mPending[5];                                // by Kind, highest first
    std::map<uint64_t, Request> mInFlight;
    uint64_t mNextId = 1;
    uint64_t mDownloaded = 0, mFailed = 0;
    std::vector<std::string> mLog;
    std::map<int, CachedTexture> mTextureCache;  // by node
    int mCurrentCell = -1;
    // coverageHintOfNodes' answer and what it was built from: a cell's file is set once, and new
    // nodes come only with new cell files.
    int mHintCell = -1;
    size_t mHintNodes = 0;
    std::vector<double> mHintOfNode;
    Vec3 mLastEye{0.0f}, mLastTarget{0.0f};
    double mLastMoveS = 0.0, mLastFrameS = -1.0;
    Vec3 mVelocity{0.0f};
};

}  // namespace plx::stream
