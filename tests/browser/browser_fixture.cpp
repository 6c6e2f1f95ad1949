// The browser test's fixture (tests/browser/browser_test.mjs): writes, for a known scene and
// pose, what a server would send a browser (the encoded ServerHello and one ReferenceSet message,
// coded as the server codes them for a client that decodes only q16-deflate; a Ping and the Pong
// that answers it), the embedded page (through webAsset, as the server serves it), and the native
// client's frame for a destination pose: the same message decoded by libs/remote and warped by
// warp::Warper. The browser warps the same bytes to the same pose, so the two frames differ only
// by the two warps.
//
// With a server's address it writes the native client's frame from a live session instead
// (tests/browser/browser_live_test.mjs): a libs/remote Client receives the server's set for the
// reference pose and warps it to the destination pose.
//
// Usage: plx_browser_fixture OUTDIR [ws://HOST:PORT]

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/format.h>

#include <plx/core/image_io.h>
#include <plx/raster/raster.h>
#include <plx/remote/client.h>
#include <plx/remote/protocol.h>
#include <plx/remote/transport.h>
#include <plx/scene/generators.h>
#include <plx/warp/reference.h>

#include "web_assets.h"

namespace {

using namespace plx;
namespace fs = std::filesystem;

// office:1's default viewpoint, 128-pixel cube4 faces (65,536 points: quick under SwiftShader);
// the display 15 cm right and 10 cm forward of the reference pose, turned 10 degrees right, at
// 320 x 180 with the page's 60-degree field of view.
constexpr const char* kScene = "office:1";
constexpr int kFaceSize = 128;
constexpr int kWidth = 320, kHeight = 180;

Status writeBytes(const fs::path& path, std::span<const uint8_t> bytes) {
    return writeFileBytes(path.string(), bytes);
}

Status writeWeb(const fs::path& dir) {
    fs::create_directories(dir);
    for (const cli::EmbeddedFile& f : cli::webFiles()) {
        std::string path = "/";
        path += f.name;
        const auto asset = cli::webAsset(path);
        if (!asset) return {ErrorCode::kInternal, fmt::format("web asset {} not served", f.name)};
        PLX_RETURN_IF_ERROR(writeBytes(dir / std::string(f.name), asset->bytes));
    }
    return {};
}

std::string vec(const Vec3& v) {
    return fmt::format("[{:.9g}, {:.9g}, {:.9g}]", v.x, v.y, v.z);
}

// The native client's frames of `set` (rendered for `pose`) at the destination pose (the
// derivative and the point kernel) and pose.json: both poses, the hole count, the set's bytes,
// the face size.
Status writeNative(const fs::path& out, const warp::ReferenceSet& set, const warp::Pose& pose,
                   size_t setBytes) {
    const Vec3 right = glm::normalize(glm::cross(pose.forward, pose.up));
    const float turn = radians(10.0f);
    const Vec3 eye = pose.eye + 0.15f * right + 0.1f * pose.forward;
    const Vec3 forward = glm::normalize(std::cos(turn) * pose.forward + std::sin(turn) * right);
    CameraDesc d;
    d.eyePos = eye;
    d.targetPos = eye + forward;
    d.upDir = pose.up;
    d.fovYDegrees = 60.0f;
    d.nearPlane = 0.05f;
    d.farPlane = 1000.0f;
    d.width = kWidth;
    d.height = kHeight;
    Result<Camera> destination = Camera::create(d);
    if (!destination) return destination.status();
    Result<std::unique_ptr<warp::Warper>> warper = warp::Warper::create(2);
    if (!warper) return warper.status();
    // The page has no hole fill: what no splat covers stays the clear colour in both.
    warp::WarpOptions warpOptions;
    warpOptions.fillHoles = false;
    warp::WarpFrame frame;
    warp::WarpStats stats;
    PLX_RETURN_IF_ERROR((*warper)->warp(set, *destination, warpOptions, &frame, &stats));
    PLX_RETURN_IF_ERROR(writePng((out / "native.png").string(), frame.color));
    // The point kernel's frame too (one pixel per source pixel): it isolates the warped
    // positions and the z-test from the derivative splat's extents.
    warp::WarpFrame points;
    warpOptions.splat = warp::Splat::kPoint;
    PLX_RETURN_IF_ERROR((*warper)->warp(set, *destination, warpOptions, &points));
    PLX_RETURN_IF_ERROR(writeBytes(
        out / "native_point.rgba",
        {reinterpret_cast<const uint8_t*>(points.color.data()), points.color.pixelCount() * 4}));
    PLX_RETURN_IF_ERROR(writeBytes(
        out / "native.rgba",
        {reinterpret_cast<const uint8_t*>(frame.color.data()), frame.color.pixelCount() * 4}));
    const std::string json = fmt::format(
        "{{\"width\": {}, \"height\": {}, \"eye\": {}, \"forward\": {}, \"up\": {}, "
        "\"reference\": {{\"eye\": {}, \"forward\": {}, \"up\": {}}}, \"holePixels\": {}, "
        "\"setBytes\": {}, \"faceSize\": {}}}\n",
        kWidth, kHeight, vec(eye), vec(forward), vec(pose.up), vec(pose.eye), vec(pose.forward),
        vec(pose.up), stats.holePixels, setBytes, kFaceSize);
    return writeBytes(out / "pose.json",
                      {reinterpret_cast<const uint8_t*>(json.data()), json.size()});
}

Status runOffline(const fs::path& out, const scene::Scene& scene) {
    PLX_RETURN_IF_ERROR(writeWeb(out / "web"));
    Result<std::unique_ptr<raster::Renderer>> renderer = raster::Renderer::create({2});
    if (!renderer) return renderer.status();
    const warp::Pose pose = warp::poseAt(scene.viewpoints.front());
    warp::ReferenceSetOptions options;
    options.faceSize = kFaceSize;
    remote::ReferenceSetMessage message;
    PLX_RETURN_IF_ERROR(warp::renderReferenceSet(**renderer, scene, pose, options, &message.set));

    // What the server sends a browser: its hello, then the set with the codec it picks for
    // ClientHello's mask of q16-deflate only.
    remote::ServerHello hello;
    hello.faceSize = kFaceSize;
    hello.poseRateHz = 60;
    Result<std::vector<uint8_t>> helloBytes = remote::encodeMessage(hello);
    if (!helloBytes) return helloBytes.status();
    remote::CodecOptions codec;
    Result<remote::DisparityCodec> chosen = remote::chooseDisparityCodec(
        remote::disparityCodecBit(remote::DisparityCodec::kQuantized16Deflate));
    if (!chosen) return chosen.status();
    codec.disparity = *chosen;
    Result<std::vector<uint8_t>> setBytes = remote::encodeMessage(message, codec);
    if (!setBytes) return setBytes.status();
    PLX_RETURN_IF_ERROR(writeBytes(out / "server_hello.bin", *helloBytes));
    PLX_RETURN_IF_ERROR(writeBytes(out / "reference_set.bin", *setBytes));
    // A server's Ping and the Pong that answers it, every byte of both fields set.
    constexpr uint64_t kPingTime = 0x0123456789abcdefull;
    constexpr uint32_t kPingNonce = 0xa1b2c3d4u;
    for (auto [name, control] :
         {std::pair<const char*, remote::Message>{"ping.bin", remote::Ping{kPingTime, kPingNonce}},
          {"pong.bin", remote::Pong{kPingTime, kPingNonce}}}) {
        Result<std::vector<uint8_t>> bytes = remote::encodeMessage(control);
        if (!bytes) return bytes.status();
        PLX_RETURN_IF_ERROR(writeBytes(out / name, *bytes));
    }

    // The native client: the same bytes decoded and warped.
    Result<remote::Message> decoded = remote::decodeMessage(*setBytes);
    if (!decoded) return decoded.status();
    return writeNative(out, std::get<remote::ReferenceSetMessage>(*decoded).set, pose,
                       setBytes->size());
}

// Live: the native client's frame from a running server. A libs/remote Client (the code of
// `parallax client`) asks `url` for a set at the reference pose and warps the first one it
// receives, as the page does with its own session.
Status runLive(const fs::path& out, const scene::Scene& scene, const std::string& url) {
    Result<remote::WsUrl> where = remote::parseWsUrl(url);
    if (!where) return where.status();
    remote::ClientConfig config;
    config.host = where->host;
    config.port = where->port;
    config.path = where->path;
    config.faceSize = kFaceSize;
    Result<std::unique_ptr<remote::Client>> client = remote::Client::create(config);
    if (!client) return client.status();
    const warp::Pose pose = warp::poseAt(scene.viewpoints.front());
    remote::PoseMessage message;
    message.timestampUs = remote::clientNowUs();
    message.pose = pose;
    (*client)->setPose(message);
    const bool arrived = (*client)->waitForFirst(20000.0);
    std::shared_ptr<const remote::ReceivedSet> received = (*client)->newest();
    const Status fatal = (*client)->fatal();
    (*client)->stop();
    if (!arrived || !received)
        return {ErrorCode::kIoError,
                fmt::format("no reference set from {}{}", url,
                            fatal.isOk() ? std::string() : ": " + fatal.message())};
    return writeNative(out, received->set, received->set.pose, received->bytes);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2 && argc != 3) {
        std::fprintf(stderr, "usage: plx_browser_fixture OUTDIR [ws://HOST:PORT]\n");
        return 2;
    }
    Result<scene::Scene> scene = scene::generateFromSpec(kScene);
    const Status s = !scene      ? scene.status()
                     : argc == 3 ? runLive(argv[1], *scene, argv[2])
                                 : runOffline(argv[1], *scene);
    if (!s.isOk()) {
        std::fprintf(stderr, "plx_browser_fixture: error: %s\n", s.message().c_str());
        return 1;
    }
    return 0;
}
