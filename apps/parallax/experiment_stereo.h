#pragma once
// The experiment of Heo, Jung, Wohn Table 1 and Fig. 17, with the reproject method of Fu, Bao,
// Peng beside it: office:N for growing N, every method, per N the polygon counts, the time of
// each eye, the pair speedups and the second eye's quality. Typed rows; JSON, CSV, markdown tables
// and plots are made from them.

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include <plx/stereo/stereo.h>

namespace plx::cli {

struct StereoExperimentConfig {
    std::vector<int> rooms{1, 2, 3, 4, 8, 15, 32, 64, 128, 280};  // 280: over 1M triangles
    int width = 640, height = 480;
    int frames = 7;  // timed frames per method (median), methods interleaved; one warm-up each
    int threads = 0;
    StereoRigDesc rig;                                 // default separation and convergence
    raster::Shading shading = raster::Shading::kFlat;  // the paper's constant shading
    bool conservative = true;                          // also measure the conservative option
    bool reproject = true;                             // also measure the reproject method
};

struct StereoExperimentRow {
    int rooms = 0;
    size_t polygons = 0, visiblePolygons = 0;
    double fullFirstMs = 0, fullSecondMs = 0;  // full pipeline, each eye
    double pbufferFirstMs = 0, pbufferSecondMs = 0, collectMs = 0;
    double pairSpeedup = 0;                             // full pair / pbuffer pair
    double secondEyePsnrDb = 0, differingFraction = 0;  // infinite PSNR: identical eyes
    size_t missedPolygons = 0;
    int64_t missedPixels = 0;
    // Conservative option (zero when not measured).
    size_t conservativeExtra = 0;
    double conservativeFirstMs = 0, conservativeSecondMs = 0, conservativePsnrDb = 0;
    size_t conservativeMissedPolygons = 0;
    int64_t conservativeMissedPixels = 0;
    // Reproject method (zero when not measured); second = reproject + fill.
    double reprojectPrepareMs = 0;  // the box hierarchy, once per scene, untimed
    double reprojectFirstMs = 0, reprojectSecondMs = 0, reprojectMs = 0, fillMs = 0;
    double reprojectPairSpeedup = 0;  // full pair / reproject pair
    double reprojectPsnrDb = 0, reprojectIdenticalFraction = 0;
    double reprojectHoleFraction = 0;  // second-eye hole pixels (reproject.h)
    size_t reprojectExpansionHoles = 0, reprojectDisocclusionHoles = 0;
    size_t reprojectFillPolygonsDrawn = 0;
    int64_t reprojectMissedPixels = 0;
};

// The experiment's peak bytes beyond its scenes, for checkImageMemory: each method's pair (both
// eyes' colour, depth and IDs) and the renderer's targets, by the pixel.
double stereoExperimentImageBytes(const StereoExperimentConfig& config);
// And its scenes' (generated after the check): the largest row's office, the renderer's memory
// for it and the reprojection's search structures, and the same but the office for the next
// largest row, which the allocator may still hold when the largest comes (office:280 after
// office:128 peaks 48 MB above office:280 alone).
double stereoExperimentSceneBytes(const StereoExperimentConfig& config);

// Runs the experiment; progress(i, n) is called after each row. Errors: bad config or scenes.
Result<std::vector<StereoExperimentRow>> runStereoExperiment(
    const StereoExperimentConfig& config,
    const std::function<void(size_t, size_t)>& progress = nullptr);

// {"width", "height", "frames", "separation", "convergence", "rows": [...]}: the document
// `parallax bench stereo --json` prints. JSON has no infinity: an infinite PSNR reads 99 dB. The
// columns of a measurement the config skips (conservative_*, reproject_* and fill_ms) are null.
nlohmann::json stereoExperimentJson(const StereoExperimentConfig& config,
                                    const std::vector<StereoExperimentRow>& rows);
// The rows as CSV (one header line), infinite PSNR as 99 dB; the columns of a measurement the
// config skips (conservative, reproject) empty.
std::string stereoExperimentCsv(const StereoExperimentConfig& config,
                                const std::vector<StereoExperimentRow>& rows);

// Fig. 17 of Heo, Jung, Wohn from an experiment: (a) first-eye time, (b) second-eye time,
// (c) pair time, each for both methods against the polygon count; plus the pair speedup, the
// visible polygons and the second-eye time of all three methods (second_eye_methods.svg, with the
// reproject method when measured). Returns (file name, SVG) pairs.
std::vector<std::pair<std::string, std::string>> stereoPlots(
    const std::vector<StereoExperimentRow>& rows);

// Markdown tables for docs/stereo-results.md. The three methods side by side (second eye, pair
// speedups, quality), and Fu, Bao, Peng's timing table (polygons, left, right, total) for the
// reproject method, the first eye as "left", plus the once-per-scene preparation. Both need rows
// measured with the reproject method.
std::string stereoMethodsMarkdown(const std::vector<StereoExperimentRow>& rows);
std::string reprojectPaperTableMarkdown(const std::vector<StereoExperimentRow>& rows);

}  // namespace plx::cli
