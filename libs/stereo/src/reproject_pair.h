#pragma once
// The reproject method's frame (Fu, Bao, Peng) inside StereoRenderer: what it keeps per scene
// (the fill's box hierarchy, and its BSP tree for the BSP search) and per frame (scratch planes,
// holes, fill memory).

#include <memory>
#include <optional>

#include <plx/core/parallel.h>
#include <plx/stereo/fill.h>
#include <plx/stereo/holes.h>
#include <plx/stereo/reproject.h>
#include <plx/stereo/stereo.h>
#include <plx/stereo/unseen.h>

namespace plx::stereo {

class ReprojectPair {
public:
    explicit ReprojectPair(int threads) : mPool(threads) {}

    // StereoRenderer::prepareReprojection.
    Status prepare(const scene::Scene& scene, FillSearch search);
    double lastPrepareMs() const { return mPrepareMs; }
    // Whether prepare() ran for this scene (address, size and a fingerprint of its geometry) and
    // built what `search` walks.
    bool preparedFor(const scene::Scene& scene, FillSearch search) const;

    // Renders the pair: first eye with depth and IDs, reprojection, holes found, classified and
    // filled, then what the first eye could not see drawn over them (unseen.h). Precondition:
    // preparedFor(scene, options.fillSearch); frame's eyes sized by the caller.
    void render(raster::Renderer& renderer, const scene::Scene& scene, const StereoRig& rig,
                const StereoOptions& options, StereoFrame* frame, StereoFrameStats* stats);

private:
    struct SceneKey {
        const scene::Scene* address = nullptr;
        size_t triangles = 0;
        Vec3 firstVertex{0.0f}, lastVertex{0.0f};
        bool operator==(const SceneKey&) const = default;
    };
    static SceneKey keyOf(const scene::Scene& scene);
    const OffsetLut& lutFor(const DisparityLine& line, const Camera& camera);

    ThreadPool mPool;
    std::optional<SceneKey> mKey;
    FillScene mFill;
    double mPrepareMs = 0.0;
    // Depth and ID planes for eyes whose frame planes are not written (writeDepthAndIds false),
    // shared by both eyes.
    raster::FrameBuffers mScratchPlanes;
    HoleRuns mHoleRuns;  // the row pass's hole runs, which findHoles merges
    HoleScratch mHoleScratch;
    HoleSet mHoles;
    FillScratch mFillScratch;
    UnseenScratch mUnseenScratch;
    std::optional<OffsetLut> mLut;
    DisparityLine mLutLine;
    float mLutMaxInvW = 0.0f;
};

}  // namespace plx::stereo
