// Renders with the installed library as README's "Using the library from CMake" does, then a
// reprojected stereo pair checked against the full method, and a PTM round trip; touches the
// other modules through calls that need no GPU or network. Prints one line and exits 0, or names
// what failed and exits 1.
#include <plx/core/metrics.h>
#include <plx/display/display_json.h>
#include <plx/gl/gl_renderer.h>
#include <plx/ptm/decoder.h>
#include <plx/ptm/encoder.h>
#include <plx/raster/raster.h>
#include <plx/remote/server.h>
#include <plx/scene/import.h>
#include <plx/stereo/stereo.h>
#include <plx/stream/http_fetch.h>
#include <cstdio>
#include <cstring>

namespace {

int fail(const char* what, const char* why) {
    std::fprintf(stderr, "consumer: %s: %s\n", what, why);
    return 1;
}

int fail(const char* what, const plx::Status& status) {
    return fail(what, status.message().c_str());
}

plx::ByteImage toByteImage(const plx::Image<plx::Rgba8>& color) {
    plx::ByteImage bytes{color.width(), color.height(), 4, {}};
    bytes.bytes.resize(bytes.rowBytes() * size_t(bytes.height));
    for (int y = 0; y < color.height(); ++y) {
        std::memcpy(bytes.pixel(0, y), color.row(y), bytes.rowBytes());
    }
    return bytes;
}

}  // namespace

int main(int argc, char** argv) {
    auto scene = plx::scene::loadScene("office:2");
    if (!scene) return fail("loadScene", scene.status());
    plx::CameraDesc desc;
    desc.eyePos = {1.0f, 1.6f, 1.0f};
    desc.targetPos = {6.0f, 1.0f, 6.0f};
    desc.width = 320;
    desc.height = 240;
    auto camera = plx::Camera::create(desc);
    if (!camera) return fail("Camera::create", camera.status());
    auto renderer = plx::raster::Renderer::create({/*threads*/ 0});
    if (!renderer) return fail("Renderer::create", renderer.status());
    plx::raster::FrameBuffers fb;
    fb.resize(desc.width, desc.height);
    (*renderer)->render(*scene, *camera, {}, fb.targets());
    const size_t visible = plx::raster::countDistinctIds(fb.id);
    if (visible == 0) return fail("render", "no triangle drawn");

    auto rig = plx::StereoRig::create(*camera, {});
    auto stereo = plx::stereo::StereoRenderer::create();
    if (!rig || !stereo) return fail("stereo set-up", "refused");
    if (auto prepared = (*stereo)->prepareReprojection(*scene); !prepared.ok()) {
        return fail("prepareReprojection", prepared);
    }
    plx::stereo::StereoFrame full, reprojected;
    plx::stereo::StereoOptions options;
    options.method = plx::stereo::Method::kFull;
    (*stereo)->renderPair(*scene, *rig, options, &full);
    options.method = plx::stereo::Method::kReproject;
    (*stereo)->renderPair(*scene, *rig, options, &reprojected);
    const double psnr = plx::psnr(full.right.color, reprojected.right.color);
    if (psnr < 30.0) return fail("reproject", "second eye far from full");

    const plx::ByteImage colour = toByteImage(fb.color);
    auto encoded = plx::ptm::encode(colour);
    if (!encoded) return fail("ptm::encode", encoded.status());
    auto decoded = plx::ptm::decodeImage(*encoded);
    if (!decoded) return fail("ptm::decodeImage", decoded.status());
    if (decoded->bytes != colour.bytes) {
        return fail("ptm", "round trip not lossless");
    }

    if (!plx::remote::checkServerConfig({}).ok() ||
        !plx::stream::parseHttpUrl("http://127.0.0.1:1/db") ||
        plx::display::parseDisplayJson("{")) {
        return fail("modules", "a check gave the wrong answer");
    }
    if (argc > 1 && std::strcmp(argv[1], "--gl") == 0) {  // EGL needs Mesa; linked either way
        auto gl = plx::gl::GlRenderer::create();
        if (!gl) return fail("GlRenderer::create", gl.status());
    }
    std::printf("consumer: %zu visible triangles, reprojected second eye %.1f dB, PTM %zu bytes\n",
                visible, psnr, encoded->size());
    return 0;
}
