#pragma once
// The remote rendering experiment of Mark, Bishop, McMillan ("The Remote Rendering System",
// "Latency and Remote Display"), run for real: a render server (libs/remote Server) and a
// warping client (libs/remote Client) in this one process, talking WebSocket over loopback with
// the server's link emulation adding the round trip and the bandwidth. The client plays a
// walkthrough in real time at 60 Hz; per setting it measures its frame rate, its warp time, the
// reference sets' rate and size, and, after the session, the PSNR of each method's frames
// against the render at the frame's pose: this system (the newest set warped), plain video
// streaming (the newest received frame shown as is) and rotation-only timewarp of that frame.

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include <plx/remote/protocol.h>
#include <plx/warp/warp.h>

namespace plx::cli {

enum class RemoteMethod {
    kWarp,      // this system: the newest reference set warped to the current pose
    kVideo,     // plain video streaming: the newest received frame shown as is
    kTimewarp,  // that frame, rotation-only timewarped to the current pose
};
inline constexpr RemoteMethod kRemoteMethods[] = {RemoteMethod::kWarp, RemoteMethod::kVideo,
                                                  RemoteMethod::kTimewarp};
const char* remoteMethodName(RemoteMethod method);  // warp, video, timewarp

// The reference sets a remote client asks for to show `display`: the display's density
// (referenceDensityFor) in faces the protocol allows (remote::kMinFaceSize .. kMaxFaceSize) and
// a server renders (remote::maxServedFaceSize: a wide view at most 4096 pixels wide).
warp::ReferenceSetOptions remoteReferenceFor(const Camera& display, warp::ReferenceLayout layout);

// One link setting: the round trip the server's emulation adds (half each way) and its rate.
struct LinkSetting {
    double rttMs = 0.0;
    double bandwidthMbit = 1000.0;
};

struct RemoteExperimentConfig {
    std::vector<std::string> scenes{"office:8", "museum:4"};  // walkthroughs (builtinWalk)
    // The RTT sweep at 1000 Mbit/s, then the bandwidth sweep at RTT 100 ms.
    std::vector<LinkSetting> links{{0, 1000},   {50, 1000}, {100, 1000}, {200, 1000},
                                   {500, 1000}, {100, 100}, {100, 10}};
    int width = 320, height = 240;  // the display (the paper's 320x240)
    double leadInS = 1.0;           // played before measuring (the first sets, the first RTT)
    double durationS = 3.0;         // measured display time per setting
    int psnrEvery = 4;              // PSNR on every Nth measured frame
    warp::ReferenceLayout layout = warp::ReferenceLayout::kCube4;
    int threads = 0;  // the server's render threads and the client's warp threads (0: all)
    // Keep one measured frame's images (the middle kept frame of the first scene's first
    // session at this RTT); negative: none.
    double exampleRttMs = -1.0;
};

// Medians over one session's measured frames, for one method.
struct RemoteRow {
    std::string scene;
    double rttMs = 0.0, bandwidthMbit = 0.0;
    RemoteMethod method = RemoteMethod::kWarp;
    int frames = 0;               // display frames measured
    int psnrFrames = 0;           // of which compared with the truth
    double clientFps = 0.0;       // the session's display loop (it warps every frame)
    double warpMsMedian = 0.0;    // the method's per-frame cost (video: 0)
    double referencesPerS = 0.0;  // sets (or frames) received per second
    double bytesPerReference = 0.0;
    double referenceAgeMsMedian = 0.0;  // now - the shown set's pose timestamp
    double psnrDbMedian = 0.0;          // against the render at the frame's pose; 99 identical
    double rttMeasuredMs = 0.0;         // the client's smoothed ping
};

// One display frame of a session as each method showed it, beside the render at its pose.
struct RemoteExample {
    struct Shown {
        RemoteMethod method;
        Image<Rgba8> image;
        double psnrDb = 0.0;
    };
    std::string scene;
    double rttMs = 0.0;
    int frame = 0;  // display frame, counted from the session's start
    Image<Rgba8> truth;
    std::vector<Shown> images;  // in kRemoteMethods order
};

struct RemoteExperiment {
    RemoteExperimentConfig config;
    std::vector<RemoteRow> rows;
    std::optional<RemoteExample> example;  // when config.exampleRttMs asked for one
    std::vector<std::string> notes;
};

// Errors: no scene or link, an RTT outside 0 .. 10 s, a bandwidth outside 0.01 .. 100000
// Mbit/s, a size, duration or PSNR step out of range.
Status checkRemoteExperimentConfig(const RemoteExperimentConfig& config);

// The experiment's peak bytes, for checkImageMemory: one session's reference sets on both sides
// of the socket, and its display frames, those kept for the PSNR pass included, with the largest
// generated scene and two renderers for it (the truth frames' and the server's).
// Errors: a size no camera takes, a bad scene spec.
Result<double> remoteExperimentBytes(const RemoteExperimentConfig& config);

// Runs one session per scene and link; progress(done, total) after each. Errors: those of
// checkRemoteExperimentConfig, a scene that does not load, a server or client that fails.
Result<RemoteExperiment> runRemoteExperiment(
    const RemoteExperimentConfig& config,
    const std::function<void(size_t, size_t)>& progress = nullptr);

// {"width", "height", ..., "rows": [{"scene", "rtt_ms", "bandwidth_mbit", "method",
// "client_fps", "warp_ms_median", "references_per_s", "bytes_per_reference",
// "reference_age_ms_median", "psnr_db_median", "frames", "psnr_frames", "rtt_measured_ms"}],
// "notes": [...]}: the document `parallax bench remote --json` prints.
nlohmann::json remoteExperimentJson(const RemoteExperiment& experiment);
std::string remoteCsv(const RemoteExperiment& experiment);
// PSNR against RTT per method and scene (the 1000 Mbit/s sweep), PSNR against bandwidth (RTT
// 100 ms), client frames/s against RTT. (file name, SVG) pairs.
std::vector<std::pair<std::string, std::string>> remotePlots(const RemoteExperiment& experiment);

// The median PSNR of `method` minus that of plain video at one scene and RTT (first matching
// bandwidth); NaN when a row is missing.
double psnrGainOverVideo(const RemoteExperiment& experiment, const std::string& scene, double rttMs,
                         RemoteMethod method = RemoteMethod::kWarp);

// The pose message of display frame f of a path shown at displayHz: its camera and the eye's
// velocity along the path (central difference; the server predicts with it).
remote::PoseMessage displayPoseMessage(const std::vector<Camera>& cameras, int frame,
                                       double displayHz);

}  // namespace plx::cli
