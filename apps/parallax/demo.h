#pragma once
// Sections of `parallax demo`. Each capability adds one function that renders its part of the
// report into ctx.outDir and records its headline numbers in ctx.summary.

#include <nlohmann/json.hpp>

#include "report.h"

namespace plx::cli {

struct DemoContext {
    std::string outDir;          // where the report and its images go
    HtmlReport* report = nullptr;
    nlohmann::json* summary = nullptr;  // section name -> its numbers (printed with --json)
    int threads = 0;
    bool quick = false;          // smaller sizes for tests
};

// Foundation: office:1..16 rendered with the P-buffer rasterizer, images and the frame-time plot.
Status demoRasterSection(DemoContext& ctx);

// Stereo (Heo, Jung, Wohn): the Table 1 / Fig. 17 experiment, an anaglyph, the second-eye diff.
Status demoStereoSection(DemoContext& ctx);

// Latency compensation (Mark, Bishop, McMillan): a walkthrough frame through a 100 ms round trip
// (stale, timewarped, warped, the truth) and the PSNR-against-RTT plot. ctx.quick: tiny sizes.
Status demoWarpSection(DemoContext& ctx);

// Remote rendering (Mark, Bishop, McMillan): a short loopback session of server and warping
// client at a few round trips; one frame at RTT 100 ms as warp, plain video and timewarp showed
// it, and the PSNR-against-RTT plot. ctx.quick: tiny sizes, two round trips.
Status demoRemoteSection(DemoContext& ctx);

// Curved displays (Bimber et al.): the cone showcase's adaptive grid, the predistorted frame,
// uniform against adaptive and the speedup plot. ctx.quick: two thresholds, small sizes.
Status demoDisplaySection(DemoContext& ctx);

// Progressive texture maps (Marvie, Bouatouch): a texture's PTM levels as they arrive, the bytes
// per level, the size against PNG. Falls back to the office:4 render without the shared data.
Status demoPtmSection(DemoContext& ctx);

// Texture streaming (Marvie, Bouatouch): museum:4's database walked through every room at four
// bandwidths; quality and resident bytes over time, frames at 10, 35 and 80 s at 56 kbit/s.
Status demoStreamSection(DemoContext& ctx);

}  // namespace plx::cli
