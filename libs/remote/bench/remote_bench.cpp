// Google Benchmark and experiment driver for the reference-set codec (issue 26, item 2): bytes
// per cube4 set of 512-pixel faces against raw (4 B colour + 4 B disparity per pixel), encode and
// decode milliseconds per set (one thread), and each choice's cost in the warped frame: the
// decoded set and the original set warped to a nearby pose with warp::Warper, PSNR of the one
// against the other. Lossless peers: PNG (libpng, level 6) and zstd of raw RGB for colour, zstd
// of raw floats for disparity. Table: docs/remote-results.md.
#include <algorithm>
#include <cmath>
#include <ctime>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include <plx/core/image_io.h>
#include <plx/core/metrics.h>
#include <plx/core/timing.h>
#include <plx/raster/raster.h>
#include <plx/remote/codec.h>
#include <plx/scene/generators.h>
#include <plx/scene/import.h>
#include <plx/warp/reference.h>
#include <plx/warp/warp.h>

#include "payloads.h"

namespace {

using namespace plx;
using namespace plx::remote;

// The generators' office and museum, and a real textured model (skipped when the shared data is
// absent): the generators' flat-shaded surfaces flatter lossless colour coders.
const std::string kScenes[] = {"office:1", "museum:3",
                               PLX_SHARED_DATA_DIR "/models/DamagedHelmet/DamagedHelmet.glb"};

// CPU time of the whole process (a set's views are coded on several threads): the shared
// machine's wall clock also counts others' work.
double processCpuMs() {
    timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

// A scene's cube4 set at its first viewpoint, the display camera 10 cm right and forward of it
// turned 10 degrees (the warp bench's display loop), and the original set's warp to it.
struct Setup {
    warp::ReferenceSet set;
    Camera destination{*Camera::create({})};
    warp::WarpFrame reference;
    std::unique_ptr<warp::Warper> warper = std::move(warp::Warper::create(2)).value();

    explicit Setup(const scene::Scene& scene) {
        auto renderer = std::move(raster::Renderer::create({2})).value();
        const warp::Pose pose = warp::poseAt(scene::defaultViewpoint(scene));
        warp::ReferenceSetOptions o;
        o.faceSize = 512;
        if (!warp::renderReferenceSet(*renderer, scene, pose, o, &set).isOk()) std::abort();
        const Vec3 right = glm::normalize(glm::cross(pose.forward, pose.up));
        const float t = radians(10.0f);
        CameraDesc d;
        d.eyePos = pose.eye + right * 0.1f + pose.forward * 0.1f;
        d.targetPos = d.eyePos + glm::normalize(pose.forward * std::cos(t) + right * std::sin(t));
        d.upDir = pose.up;
        destination = *Camera::create(d);
        if (!warper->warp(set, destination, {}, &reference).isOk()) std::abort();
    }
};

// Null when the scene cannot be loaded (the shared data is absent).
const Setup* cached(const std::string& spec) {
    static std::map<std::string, std::unique_ptr<Setup>> setups;
    auto& slot = setups[spec];
    if (!slot) {
        Result<scene::Scene> scene = scene::loadScene(spec);
        if (!scene) return nullptr;
        slot = std::make_unique<Setup>(*scene);
    }
    return slot.get();
}

std::string sceneName(int64_t i) {
    return i == 2 ? "DamagedHelmet" : kScenes[i];
}

struct Choice {
    const char* name;
    CodecOptions options;
};

CodecOptions jpeg(int quality, ChromaSubsampling chroma) {
    CodecOptions o;
    o.jpegQuality = quality;
    o.chroma = chroma;
    return o;
}

std::vector<Choice> choices() {
    using C = ChromaSubsampling;
    CodecOptions lossless;
    lossless.color = ColorCodec::kZstd;
    lossless.disparity = DisparityCodec::kFloatZstd;
    CodecOptions zstdColor;
    zstdColor.color = ColorCodec::kZstd;
    CodecOptions level3 = jpeg(90, C::k420), level9 = jpeg(90, C::k420);
    level3.zstdLevel = 3;
    level9.zstdLevel = 9;
    // q16's residual planes under zstd (what q16-packed re-codes), at levels 1, 3 and 9.
    CodecOptions planes1 = jpeg(90, C::k420), planes3 = planes1, planes9 = planes1;
    planes1.disparity = planes3.disparity = planes9.disparity = DisparityCodec::kQuantized16;
    planes1.zstdLevel = 1;
    planes3.zstdLevel = 3;
    planes9.zstdLevel = 9;
    // q16 with deflate (what a browser decodes), at zlib levels 1, 6 (the default) and 9.
    CodecOptions deflate1 = jpeg(90, C::k420), deflate6 = deflate1, deflate9 = deflate1;
    deflate1.disparity = deflate6.disparity = deflate9.disparity =
        DisparityCodec::kQuantized16Deflate;
    deflate1.deflateLevel = 1;
    deflate9.deflateLevel = 9;
    return {{"jpeg75-420/q16-packed", jpeg(75, C::k420)},
            {"jpeg85-420/q16-packed", jpeg(85, C::k420)},
            {"jpeg90-420/q16-packed", jpeg(90, C::k420)},
            {"jpeg95-420/q16-packed", jpeg(95, C::k420)},
            {"jpeg85-444/q16-packed", jpeg(85, C::k444)},
            {"jpeg90-444/q16-packed", jpeg(90, C::k444)},
            {"jpeg95-444/q16-packed", jpeg(95, C::k444)},
            {"jpeg90-420/q16-packed-zstd3", level3},
            {"jpeg90-420/q16-packed-zstd9", level9},
            {"jpeg90-420/q16-zstd1", planes1},
            {"jpeg90-420/q16-zstd3", planes3},
            {"jpeg90-420/q16-zstd9", planes9},
            {"jpeg90-420/q16-deflate1", deflate1},
            {"jpeg90-420/q16-deflate6", deflate6},
            {"jpeg90-420/q16-deflate9", deflate9},
            {"zstd-rgb/q16-packed", zstdColor},
            {"zstd-rgb/zstd-float (lossless)", lossless}};
}

int64_t rawBytes(const warp::ReferenceSet& set) {
    int64_t n = 0;
    for (const auto& v : set.views) n += int64_t(v.color.pixelCount()) * 8;
    return n;
}

// Colour and disparity payload bytes of an encoded view (docs/remote-protocol.md layout).
void payloadBytes(const std::vector<uint8_t>& view, int64_t* color, int64_t* disparity) {
    auto u32At = [&](size_t at) {
        return int64_t(view[at] | (view[at + 1] << 8) | (view[at + 2] << 16)) |
               (int64_t(view[at + 3]) << 24);
    };
    const size_t height = size_t(view[6] | (view[7] << 8));
    const size_t colorAt = 72 + 8 * height;
    *color += u32At(colorAt);
    *disparity += u32At(colorAt + 4 + size_t(u32At(colorAt)));
}

// args: scene, choice. Encode and decode of the whole set, timed separately, one thread.
void BM_Codec(benchmark::State& state) {
    const Setup* setup = cached(kScenes[state.range(0)]);
    if (!setup) return state.SkipWithError("scene absent");
    const Setup& s = *setup;
    const Choice choice = choices()[size_t(state.range(1))];
    state.SetLabel(sceneName(state.range(0)) + " " + choice.name);
    std::vector<double> encodeMs, decodeMs, encodeCpuMs, decodeCpuMs;
    std::vector<uint8_t> bytes;
    warp::ReferenceSet decoded;
    for (auto _ : state) {
        Stopwatch watch;
        double cpu = processCpuMs();
        bytes = std::move(encodeReferenceSet(s.set, choice.options)).value();
        encodeMs.push_back(watch.elapsedMs());
        encodeCpuMs.push_back(processCpuMs() - cpu);
        watch.restart();
        cpu = processCpuMs();
        if (!decodeReferenceSet(bytes, {}, &decoded).isOk()) std::abort();
        decodeMs.push_back(watch.elapsedMs());
        decodeCpuMs.push_back(processCpuMs() - cpu);
    }
    int64_t color = 0, disparity = 0;
    double viewPsnr = 0.0;
    for (size_t i = 0; i < s.set.views.size(); ++i) {
        auto view = std::move(encodeReferenceView(s.set.views[i], choice.options)).value();
        payloadBytes(view, &color, &disparity);
        viewPsnr += std::min(99.0, psnr(s.set.views[i].color, decoded.views[i].color));
    }
    // The q16 error bound in delta and, for 0.5 m of head motion, in pixels of warp displacement
    // at the display's focal length (docs/remote-protocol.md).
    float bound = 0.0f;
    for (const auto& v : s.set.views) bound = std::max(bound, disparityErrorBound(v.disparity));
    const double focalPx =
        0.5 * s.destination.height() / std::tan(radians(0.5f * s.destination.desc().fovYDegrees));
    state.counters["bound_delta"] = bound;
    state.counters["bound_px_0.5m"] = bound * focalPx * 0.5;
    warp::WarpFrame frame;
    if (!s.warper->warp(decoded, s.destination, {}, &frame).isOk()) std::abort();
    state.counters["KiB/set"] = double(bytes.size()) / 1024.0;
    state.counters["raw/compressed"] = double(rawBytes(s.set)) / double(bytes.size());
    state.counters["colour_KiB"] = double(color) / 1024.0;
    state.counters["disp_KiB"] = double(disparity) / 1024.0;
    state.counters["enc_ms"] = median(encodeMs);
    state.counters["dec_ms"] = median(decodeMs);
    state.counters["enc_cpu_ms"] = median(encodeCpuMs);
    state.counters["dec_cpu_ms"] = median(decodeCpuMs);
    state.counters["view_psnr_dB"] = viewPsnr / double(s.set.views.size());
    state.counters["warp_psnr_dB"] = std::min(99.0, psnr(s.reference.color, frame.color));
}
BENCHMARK(BM_Codec)
    ->ArgsProduct({{0, 1, 2}, benchmark::CreateDenseRange(0, int(choices().size()) - 1, 1)})
    ->ArgNames({"scene", "choice"})
    ->Iterations(5)
    ->Unit(benchmark::kMillisecond);

// Lossless colour peer: PNG (libpng level 6) of each view's RGB, bytes and encode time per set.
void BM_PngColor(benchmark::State& state) {
    const Setup* setup = cached(kScenes[state.range(0)]);
    if (!setup) return state.SkipWithError("scene absent");
    const Setup& s = *setup;
    state.SetLabel(sceneName(state.range(0)));
    std::vector<ByteImage> rgb;
    for (const auto& v : s.set.views) rgb.push_back(fromRgba8(v.color, 3));
    int64_t bytes = 0;
    std::vector<double> ms, cpuMs;
    for (auto _ : state) {
        bytes = 0;
        Stopwatch watch;
        const double cpu = processCpuMs();
        for (const ByteImage& image : rgb) bytes += int64_t(encodePng(image)->size());
        ms.push_back(watch.elapsedMs());
        cpuMs.push_back(processCpuMs() - cpu);
    }
    state.counters["colour_KiB"] = double(bytes) / 1024.0;
    state.counters["enc_ms"] = median(ms);
    state.counters["enc_cpu_ms"] = median(cpuMs);
}
BENCHMARK(BM_PngColor)
    ->DenseRange(0, 2)
    ->ArgName("scene")
    ->Iterations(3)
    ->Unit(benchmark::kMillisecond);

// Colour on photographic content: four Sponza textures cut to 512x512 faces (the generators'
// and the helmet's frames are mostly flat colour, which flatters lossless coders). args: choice
// 0 JPEG q90 4:2:0, 1 JPEG q90 4:4:4, 2 zstd RGB, 3 PNG.
void BM_PhotoColor(benchmark::State& state) {
    static const char* const kFiles[] = {"10381718147657362067.jpg", "10388182081421875623.jpg",
                                         "11474523244911310074.jpg", "11872827283454512094.jpg"};
    std::vector<Image<Rgba8>> faces;
    for (const char* f : kFiles) {
        Result<ByteImage> image =
            readImage(PLX_SHARED_DATA_DIR "/textures/sponza/" + std::string(f));
        if (!image || image->width < 512 || image->height < 512) {
            return state.SkipWithError("Sponza textures absent");
        }
        const Image<Rgba8> full = toRgba8(*image);
        Image<Rgba8> face(512, 512);
        for (int y = 0; y < 512; ++y) std::copy_n(full.row(y), 512, face.row(y));
        faces.push_back(std::move(face));
    }
    const int choice = int(state.range(0));
    static const char* const kNames[] = {"jpeg90-420", "jpeg90-444", "zstd-rgb", "png"};
    state.SetLabel(kNames[choice]);
    CodecOptions o = jpeg(90, choice == 1 ? ChromaSubsampling::k444 : ChromaSubsampling::k420);
    if (choice == 2) o.color = ColorCodec::kZstd;
    int64_t bytes = 0;
    double quality = 0.0;
    for (auto _ : state) {
        bytes = 0;
        quality = 0.0;
        for (const Image<Rgba8>& face : faces) {
            warp::ReferenceView v;
            CameraDesc d;
            d.width = d.height = 512;
            v.camera = *Camera::create(d);
            v.color = face;
            v.disparity.resize(512, 512, 0.5f);
            warp::computeRowDisparityRange(&v);
            if (choice == 3) {
                bytes += int64_t(encodePng(fromRgba8(face, 3))->size());
                quality += 99.0;
                continue;
            }
            auto encoded = std::move(encodeReferenceView(v, o)).value();
            int64_t disparity = 0;
            payloadBytes(encoded, &bytes, &disparity);
            warp::ReferenceView back;
            if (!decodeReferenceView(encoded, {}, &back).isOk()) std::abort();
            quality += std::min(99.0, psnr(face, back.color));
        }
    }
    state.counters["colour_KiB"] = double(bytes) / 1024.0;
    state.counters["raw_rgba/colour"] = 4.0 * 4 * 512 * 512 / double(bytes);
    state.counters["view_psnr_dB"] = quality / 4.0;
}
BENCHMARK(BM_PhotoColor)
    ->DenseRange(0, 3)
    ->ArgName("choice")
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond);

// The disparity hot paths of a server and a client, per cube4 set of office:1 (four 512-pixel
// faces, one thread): the view's range, the q16 residual planes and zstd (encode), and back
// (decode); arg 0 the pixel-by-pixel reference (disparity_q16_reference.cpp), arg 1 the codec's
// per-ISA kernels (disparity_kernels.inl, the active path: PLX_FORCE_ISA picks another). The
// ratio of the two is the kernels' worth; zstd's share is common to both. Arg 2: the codec, q16
// (residual planes under zstd) or q16-packed (two-bit symbols under zstd, and escapes).
void BM_DisparityQ16(benchmark::State& state) {
    const Setup* setup = cached(kScenes[0]);
    if (!setup) return state.SkipWithError("scene absent");
    const bool staged = state.range(0) == 1;
    const bool decode = state.range(1) == 1;
    const auto codec = DisparityCodec(state.range(2));
    const int level = CodecOptions{}.zstdLevel;
    state.SetLabel(std::string(staged ? "kernels" : "reference") +
                   (decode ? " decode" : " encode"));
    struct Encoded {
        DisparityRange range;
        std::vector<uint8_t> bytes;
    };
    std::vector<Encoded> encoded;
    for (const warp::ReferenceView& v : setup->set.views) {
        Encoded e{disparityRange(v.disparity), {}};
        if (!encodeDisparityQ16(v.disparity, e.range, codec, level, &e.bytes)) std::abort();
        encoded.push_back(std::move(e));
    }
    Image<float> out(512, 512);
    std::vector<uint8_t> bytes;
    for (auto _ : state) {
        for (size_t i = 0; i < encoded.size(); ++i) {
            const warp::ReferenceView& v = setup->set.views[i];
            if (decode) {
                Status s = staged ? decodeDisparityQ16(encoded[i].bytes, codec, encoded[i].range,
                                                       v.rowMinDisparity, v.rowMaxDisparity, &out)
                                  : reference::decodeDisparityQ16(
                                        encoded[i].bytes, codec, encoded[i].range,
                                        v.rowMinDisparity, v.rowMaxDisparity, &out);
                if (!s) std::abort();
                benchmark::DoNotOptimize(out.data());
                continue;
            }
            const DisparityRange r =
                staged ? disparityRange(v.disparity) : reference::disparityRange(v.disparity);
            Status s = staged ? encodeDisparityQ16(v.disparity, r, codec, level, &bytes)
                              : reference::encodeDisparityQ16(v.disparity, r, codec, level, &bytes);
            if (!s) std::abort();
            benchmark::DoNotOptimize(bytes.data());
        }
    }
}
BENCHMARK(BM_DisparityQ16)
    ->ArgsProduct({{0, 1},
                   {0, 1},
                   {int(DisparityCodec::kQuantized16), int(DisparityCodec::kQuantized16Packed)}})
    ->ArgNames({"staged", "decode", "disparity"})
    ->Unit(benchmark::kMillisecond);

// computeRowDisparityRange over the same set: a server runs it after every view it renders.
void BM_RowDisparityRange(benchmark::State& state) {
    const Setup* setup = cached(kScenes[0]);
    if (!setup) return state.SkipWithError("scene absent");
    warp::ReferenceSet set = setup->set;
    for (auto _ : state)
        for (warp::ReferenceView& v : set.views) warp::computeRowDisparityRange(&v);
}
BENCHMARK(BM_RowDisparityRange)->Unit(benchmark::kMillisecond);

// The session's set: office:8, cube4 faces of 1248 px (1280x720 at 60 degrees, the display's
// density; scripts/remote-measure.sh), at the scene's first viewpoint.
const warp::ReferenceSet& sessionSet() {
    static const warp::ReferenceSet set = [] {
        const scene::Scene scene = std::move(scene::loadScene("office:8")).value();
        auto renderer = std::move(raster::Renderer::create({2})).value();
        warp::ReferenceSetOptions o;
        o.faceSize = 1248;
        warp::ReferenceSet s;
        const warp::Pose pose = warp::poseAt(scene::defaultViewpoint(scene));
        if (!warp::renderReferenceSet(*renderer, scene, pose, o, &s).isOk()) std::abort();
        return s;
    }();
    return set;
}

// A server's encode and a client's decode of the session's set, JPEG colour and the disparity
// codec of arg 2 at the zstd level of arg 0, one thread (taskset -c 0 for the CPU time alone);
// KiB per set reported.
void BM_SessionSetCodec(benchmark::State& state) {
    const warp::ReferenceSet& set = sessionSet();
    CodecOptions o;
    o.zstdLevel = int(state.range(0));
    const bool decode = state.range(1) == 1;
    o.disparity = DisparityCodec(state.range(2));
    const std::vector<uint8_t> bytes = std::move(encodeReferenceSet(set, o)).value();
    warp::ReferenceSet out;
    for (auto _ : state) {
        if (decode) {
            if (!decodeReferenceSet(bytes, {}, &out).isOk()) std::abort();
        } else {
            benchmark::DoNotOptimize(encodeReferenceSet(set, o));
        }
    }
    state.counters["KiB/set"] = double(bytes.size()) / 1024.0;
    state.SetLabel(decode ? "decode" : "encode");
}
BENCHMARK(BM_SessionSetCodec)
    ->ArgsProduct({{1, 3},
                   {0, 1},
                   {int(DisparityCodec::kQuantized16), int(DisparityCodec::kQuantized16Packed)}})
    ->ArgNames({"zstd_level", "decode", "disparity"})
    ->Unit(benchmark::kMillisecond);

}  // namespace
