// PTM benchmark and experiment driver (docs/ptm-results.md).
//   plx_ptm_bench sizes [--cache CSV] FILES...
//                                  size table: raw mip chain, PNG (libpng 9), optipng -o2 PNG,
//                                  WebP lossless, JPEG XL lossless e7, PTM, residual overhead
//   plx_ptm_bench ptmspeed FILES... PTM alone (PLX_PTM_CODER=rans|raw) next to libpng decode
//   plx_ptm_bench ptmdecode FILES.. encode once (or read .ptm files), decode 20 times
//                                  (PLX_PTM_REPS=N): best MB/s;
//                                  for profilers and alternated runs of two builds
//   plx_ptm_bench speed FILES...   single-thread encode/decode MB/s of decoded base pixels
// The PTM kernels take the widest SIMD path the CPU has; PLX_FORCE_ISA=scalar|avx2|avx512 caps it.
// Peers (libwebp, libjxl, optipng) are used here only, never by the library.

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <jxl/decode.h>
#include <jxl/encode.h>
#include <webp/decode.h>
#include <webp/encode.h>

#include <plx/core/cpu.h>
#include <plx/core/image_io.h>
#include <plx/core/timing.h>
#include <plx/ptm/ptm.h>

#include "forced_isa.h"

namespace {

using plx::ByteImage;

// The coder of the "PTM" columns: PLX_PTM_CODER=raw, else the library default.
plx::ptm::EncodeConfig ptmConfig() {
    plx::ptm::EncodeConfig cfg;
    const char* c = std::getenv("PLX_PTM_CODER");
    if (c && std::string(c) == plx::ptm::coderName(plx::ptm::Coder::kRaw))
        cfg.coder = plx::ptm::Coder::kRaw;
    return cfg;
}

// WebP and our JPEG XL set-up take RGB or RGBA: grey is widened (sizes stay comparable).
ByteImage toRgbOrRgba(const ByteImage& in) {
    if (in.channels >= 3) return in;
    ByteImage out{in.width, in.height, in.channels + 2, {}};
    out.bytes.resize(out.rowBytes() * size_t(out.height));
    for (size_t i = 0, n = size_t(in.width) * in.height; i < n; ++i) {
        for (int k = 0; k < 3; ++k) out.bytes[i * out.channels + k] = in.bytes[i * in.channels];
        if (in.channels == 2) out.bytes[i * 4 + 3] = in.bytes[i * 2 + 1];
    }
    return out;
}

std::vector<uint8_t> webpEncode(const ByteImage& img) {
    uint8_t* out = nullptr;
    size_t n = img.channels == 4
                   ? WebPEncodeLosslessRGBA(img.bytes.data(), img.width, img.height,
                                            int(img.rowBytes()), &out)
                   : WebPEncodeLosslessRGB(img.bytes.data(), img.width, img.height,
                                           int(img.rowBytes()), &out);
    std::vector<uint8_t> v(out, out + n);
    WebPFree(out);
    return v;
}

bool webpDecode(const std::vector<uint8_t>& bytes, int channels) {
    int w = 0, h = 0;
    uint8_t* p = channels == 4 ? WebPDecodeRGBA(bytes.data(), bytes.size(), &w, &h)
                               : WebPDecodeRGB(bytes.data(), bytes.size(), &w, &h);
    WebPFree(p);
    return p != nullptr;
}

std::vector<uint8_t> jxlEncode(const ByteImage& img, int effort) {
    JxlEncoder* enc = JxlEncoderCreate(nullptr);
    JxlBasicInfo info;
    JxlEncoderInitBasicInfo(&info);
    info.xsize = uint32_t(img.width);
    info.ysize = uint32_t(img.height);
    info.bits_per_sample = 8;
    info.num_color_channels = 3;
    info.num_extra_channels = img.channels == 4 ? 1 : 0;
    info.alpha_bits = img.channels == 4 ? 8 : 0;
    info.uses_original_profile = JXL_TRUE;
    JxlEncoderSetBasicInfo(enc, &info);
    JxlColorEncoding color;
    JxlColorEncodingSetToSRGB(&color, JXL_FALSE);
    JxlEncoderSetColorEncoding(enc, &color);
    JxlEncoderFrameSettings* fs = JxlEncoderFrameSettingsCreate(enc, nullptr);
    JxlEncoderSetFrameLossless(fs, JXL_TRUE);
    JxlEncoderFrameSettingsSetOption(fs, JXL_ENC_FRAME_SETTING_EFFORT, effort);
    JxlPixelFormat fmt{uint32_t(img.channels), JXL_TYPE_UINT8, JXL_NATIVE_ENDIAN, 0};
    JxlEncoderAddImageFrame(fs, &fmt, img.bytes.data(), img.bytes.size());
    JxlEncoderCloseInput(enc);
    std::vector<uint8_t> out(1 << 16);
    uint8_t* next = out.data();
    size_t avail = out.size();
    JxlEncoderStatus st;
    while ((st = JxlEncoderProcessOutput(enc, &next, &avail)) == JXL_ENC_NEED_MORE_OUTPUT) {
        size_t used = size_t(next - out.data());
        out.resize(out.size() * 2);
        next = out.data() + used;
        avail = out.size() - used;
    }
    out.resize(st == JXL_ENC_SUCCESS ? size_t(next - out.data()) : 0);
    JxlEncoderDestroy(enc);
    return out;
}

bool jxlDecode(const std::vector<uint8_t>& bytes, int channels, std::vector<uint8_t>& pixels) {
    JxlDecoder* dec = JxlDecoderCreate(nullptr);
    JxlDecoderSubscribeEvents(dec, JXL_DEC_FULL_IMAGE);
    JxlDecoderSetInput(dec, bytes.data(), bytes.size());
    JxlDecoderCloseInput(dec);
    JxlPixelFormat fmt{uint32_t(channels), JXL_TYPE_UINT8, JXL_NATIVE_ENDIAN, 0};
    bool ok = false;
    for (;;) {
        JxlDecoderStatus st = JxlDecoderProcessInput(dec);
        if (st == JXL_DEC_NEED_IMAGE_OUT_BUFFER) {
            size_t n = 0;
            JxlDecoderImageOutBufferSize(dec, &fmt, &n);
            pixels.resize(n);
            JxlDecoderSetImageOutBuffer(dec, &fmt, pixels.data(), n);
        } else if (st == JXL_DEC_FULL_IMAGE) {
            ok = true;
        } else {
            ok = ok && st == JXL_DEC_SUCCESS;
            break;
        }
    }
    JxlDecoderDestroy(dec);
    return ok;
}

size_t optipngSize(const std::vector<uint8_t>& png, const std::string& tag) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::temp_directory_path();
    const std::string in = (dir / ("plx_ptm_" + tag + ".png")).string();
    const std::string out = (dir / ("plx_ptm_" + tag + "_o2.png")).string();
    if (!plx::writeFileBytes(in, png).isOk()) return 0;
    std::remove(out.c_str());
    const std::string cmd = "optipng -quiet -o2 -out '" + out + "' '" + in + "' >/dev/null 2>&1";
    if (std::system(cmd.c_str()) != 0) return 0;
    std::error_code ec;
    size_t n = size_t(fs::file_size(out, ec));
    fs::remove(in, ec);
    fs::remove(out, ec);
    return ec ? 0 : n;
}

// Peer sizes (libpng 9, optipng -o2, WebP, JPEG XL e7) of one input, cached across runs in a CSV
// (name,bytes of the input file,png9,optipng,webp,jxl) because optipng and JPEG XL are slow.
struct PeerSizes {
    size_t png = 0, opti = 0, webp = 0, jxl = 0;
};

std::string cacheKey(const std::string& file) {
    std::error_code ec;
    const auto bytes = std::filesystem::file_size(file, ec);
    return std::string(std::filesystem::path(file).filename().string()) + "," +
           std::to_string(ec ? 0 : bytes);
}

std::map<std::string, PeerSizes> loadCache(const std::string& path) {
    std::map<std::string, PeerSizes> cache;
    std::FILE* f = path.empty() ? nullptr : std::fopen(path.c_str(), "r");
    if (!f) return cache;
    char name[512];
    unsigned long long bytes = 0;
    PeerSizes p;
    while (std::fscanf(f, "%511[^,],%llu,%zu,%zu,%zu,%zu\n", name, &bytes, &p.png, &p.opti,
                       &p.webp, &p.jxl) == 6)
        cache[std::string(name) + "," + std::to_string(bytes)] = p;
    std::fclose(f);
    return cache;
}

void appendCache(const std::string& path, const std::string& key, const PeerSizes& p) {
    if (path.empty()) return;
    if (std::FILE* f = std::fopen(path.c_str(), "a")) {
        std::fprintf(f, "%s,%zu,%zu,%zu,%zu\n", key.c_str(), p.png, p.opti, p.webp, p.jxl);
        std::fclose(f);
    }
}

int runSizes(std::vector<std::string> files) {
    std::string cachePath;
    if (files.size() >= 2 && files[0] == "--cache") {
        cachePath = files[1];
        files.erase(files.begin(), files.begin() + 2);
    }
    std::map<std::string, PeerSizes> cache = loadCache(cachePath);
    struct Totals {
        double raw = 0, chain = 0, png = 0, opti = 0, webp = 0, jxl = 0, ptm = 0, ptmRaw = 0;
    } t;
    std::printf("file,w,h,c,raw,mip_chain,png9,optipng_o2,webp_ll,jxl_ll_e7,ptm,ptm_raw_coder,"
                "ptm_vs_optipng\n");
    int count = 0;
    for (const auto& f : files) {
        auto img = plx::readImage(f);
        if (!img) {
            std::fprintf(stderr, "skip %s: %s\n", f.c_str(), img.status().toString().c_str());
            continue;
        }
        ++count;
        const double raw = double(img->bytes.size());
        double chain = 0;
        for (const auto& l : plx::ptm::buildMipChain(
                 *img, plx::ptm::fullChainLength(img->width, img->height)))
            chain += double(l.bytes.size());
        const std::string key = cacheKey(f);
        PeerSizes peers;
        if (auto it = cache.find(key); it != cache.end()) {
            peers = it->second;
        } else {
            auto png = plx::encodePng(*img, 9);
            peers.png = png->size();
            peers.opti = optipngSize(*png, std::to_string(count));
            ByteImage peer = toRgbOrRgba(*img);
            peers.webp = webpEncode(peer).size();
            peers.jxl = jxlEncode(peer, 7).size();
            if (peers.opti > 0) appendCache(cachePath, key, peers);
        }
        const size_t opti = peers.opti, webp = peers.webp, jxl = peers.jxl;
        const std::vector<uint8_t> ptmFile = *plx::ptm::encode(*img, ptmConfig());
        const size_t ptm = ptmFile.size();
        auto back = plx::ptm::decodeImage(ptmFile);
        if (!back || *back != *img) {
            std::fprintf(stderr, "%s: PTM round trip FAILED %s\n", f.c_str(), back ? "mismatch" : back.status().toString().c_str());
            return 1;
        }
        plx::ptm::EncodeConfig rawCfg;
        rawCfg.coder = plx::ptm::Coder::kRaw;
        const size_t ptmRaw = plx::ptm::encode(*img, rawCfg)->size();
        std::printf("%s,%d,%d,%d,%.0f,%.0f,%zu,%zu,%zu,%zu,%zu,%zu,%.4f\n",
                    std::filesystem::path(f).filename().c_str(), img->width, img->height,
                    img->channels, raw, chain, peers.png, opti, webp, jxl, ptm, ptmRaw,
                    double(ptm) / double(opti));
        std::fflush(stdout);
        t.raw += raw, t.chain += chain, t.png += double(peers.png), t.opti += double(opti);
        t.webp += double(webp), t.jxl += double(jxl), t.ptm += double(ptm);
        t.ptmRaw += double(ptmRaw);
    }
    const double o = t.opti;
    std::printf("\n%d images. Totals in bytes (ratio to optipng -o2 PNG of the base level):\n",
                count);
    std::printf("| format | bytes | vs optipng |\n| --- | ---: | ---: |\n");
    auto row = [&](const char* name, double v) {
        std::printf("| %s | %.0f | %.3f |\n", name, v, v / o);
    };
    row("raw base level", t.raw);
    row("raw mip chain", t.chain);
    row("PTM, raw coder (paper's layout, uncompressed)", t.ptmRaw);
    row("PNG (libpng level 9)", t.png);
    row("PNG (optipng -o2)", t.opti);
    row("WebP lossless", t.webp);
    row("JPEG XL lossless e7", t.jxl);
    const std::string ptmName =
        std::string("PTM coder ") + plx::ptm::coderName(ptmConfig().coder) + " (all levels)";
    row(ptmName.c_str(), t.ptm);
    std::printf("\nuncompressed residual overhead (raw-coder PTM / raw base - 1): %.2f%%\n",
                100.0 * (t.ptmRaw / t.raw - 1.0));
    return 0;
}

template <class F>
double bestMs(int reps, F&& f) {
    std::vector<double> s;
    for (int i = 0; i < reps; ++i) {
        plx::Stopwatch w;
        f();
        s.push_back(w.elapsedMs());
    }
    return *std::min_element(s.begin(), s.end());
}

// Best of `reps` runs of f in process CPU time (ms): less sensitive than wall time to other
// processes on a shared machine.
template <class F>
double bestCpuMs(int reps, F&& f) {
    double best = 1e300;
    for (int i = 0; i < reps; ++i) {
        const std::clock_t t0 = std::clock();
        f();
        best = std::min(best, 1e3 * double(std::clock() - t0) / CLOCKS_PER_SEC);
    }
    return best;
}

int runSpeed(const std::vector<std::string>& files) {
    // Sums over the files of best-of-N times; MB/s = decoded base-level bytes / time, one thread.
    double mb = 0;
    constexpr int kCodecs = 4;
    double enc[kCodecs] = {}, dec[kCodecs] = {};
    const char* names[kCodecs] = {"PTM coder rans (default)", "PNG (libpng 9)", "WebP lossless",
                                  "JPEG XL lossless e7"};
    for (const auto& f : files) {
        auto img = plx::readImage(f);
        if (!img) continue;
        ByteImage peer = toRgbOrRgba(*img);
        mb += double(img->bytes.size()) / 1e6;
        // Decode times are process CPU time (best of N), so that other work on a shared
        // machine counts less; all codecs are measured in the same run.
        std::vector<uint8_t> file, png, webp, jxl, px;
        enc[0] += bestMs(3, [&] { file = *plx::ptm::encode(*img); });
        dec[0] += bestCpuMs(9, [&] { PLX_CHECK(plx::ptm::decodeImage(file).isOk()); });
        enc[1] += bestMs(1, [&] { png = *plx::encodePng(*img, 9); });
        enc[2] += bestMs(1, [&] { webp = webpEncode(peer); });
        enc[3] += bestMs(1, [&] { jxl = jxlEncode(peer, 7); });
        dec[1] += bestCpuMs(9, [&] { PLX_CHECK(plx::decodeImage(png).isOk()); });
        dec[2] += bestCpuMs(5, [&] { PLX_CHECK(webpDecode(webp, peer.channels)); });
        dec[3] += bestCpuMs(3, [&] { PLX_CHECK(jxlDecode(jxl, peer.channels, px)); });
    }
    std::printf("%.1f MB of base-level pixels, single thread\n", mb);
    std::printf("| codec | encode MB/s | decode MB/s (CPU time) | decode vs libpng |\n"
                "| --- | ---: | ---: | ---: |\n");
    for (int i = 0; i < kCodecs; ++i)
        std::printf("| %s | %.1f | %.1f | %.2f |\n", names[i], mb / (enc[i] / 1e3),
                    mb / (dec[i] / 1e3), dec[1] / dec[i]);
    return 0;
}

// PTM alone (PLX_PTM_CODER or the default coder): best-of-N single-thread decode and encode
// MB/s, wall and CPU time, and libpng's decode of the same images in the same run.
int runPtmSpeed(const std::vector<std::string>& files) {
    double mb = 0, encMs = 0, decMs = 0, decCpuMs = 0, pngCpuMs = 0, ptmBytes = 0;
    for (const auto& f : files) {
        auto img = plx::readImage(f);
        if (!img) continue;
        mb += double(img->bytes.size()) / 1e6;
        std::vector<uint8_t> file;
        encMs += bestMs(3, [&] { file = *plx::ptm::encode(*img, ptmConfig()); });
        ptmBytes += double(file.size());
        decMs += bestMs(5, [&] { PLX_CHECK(plx::ptm::decodeImage(file).isOk()); });
        decCpuMs += bestCpuMs(7, [&] { PLX_CHECK(plx::ptm::decodeImage(file).isOk()); });
        const std::vector<uint8_t> png = *plx::encodePng(*img, 6);
        pngCpuMs += bestCpuMs(5, [&] { PLX_CHECK(plx::decodeImage(png).isOk()); });
    }
    std::printf("PTM coder %s: %.1f MB, %.0f PTM bytes, encode %.1f MB/s, decode %.1f MB/s (one "
                "thread)\n",
                plx::ptm::coderName(ptmConfig().coder), mb, ptmBytes, mb / (encMs / 1e3), mb / (decMs / 1e3));
    std::printf("CPU time: PTM decode %.1f MB/s, libpng decode %.1f MB/s, ratio %.2f\n",
                mb / (decCpuMs / 1e3), mb / (pngCpuMs / 1e3), pngCpuMs / decCpuMs);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    if (plx::mains::refuseUnknownForcedIsa(argv[0])) return 2;
    if (argc < 3) {
        std::fprintf(stderr, "usage: plx_ptm_bench sizes|speed FILES...\n");
        return 2;
    }
    std::vector<std::string> files(argv + 2, argv + argc);
    std::string mode = argv[1];
    if (mode == "sizes") return runSizes(files);
    if (mode == "speed") return runSpeed(files);
    if (mode == "ptmspeed") return runPtmSpeed(files);
    if (mode == "ptmdecode") {  // for profilers: encode once, decode 20 (PLX_PTM_REPS) times
        const char* repsEnv = std::getenv("PLX_PTM_REPS");
        const int reps = repsEnv ? std::max(1, std::atoi(repsEnv)) : 20;
        // Every file is encoded (or, for .ptm files, read) before the first decode, so that a
        // profile of the decode loop holds no encoder samples.
        std::vector<std::vector<uint8_t>> ptms;
        double mb = 0;
        for (const auto& f : files) {
            std::vector<uint8_t> file;
            if (f.ends_with(".ptm")) {
                auto bytes = plx::readFileBytes(f);
                if (!bytes) continue;
                file = std::move(bytes).value();
            } else {
                auto img = plx::readImage(f);
                if (!img) continue;
                file = *plx::ptm::encode(*img, ptmConfig());
            }
            const plx::ptm::Header h = *plx::ptm::parseHeader(file);
            mb += double(h.width) * h.height * h.components / 1e6;
            ptms.push_back(std::move(file));
        }
        // The best decode of each file, summed: what alternated runs of two builds compare.
        double bestMs = 0;
        for (const auto& file : ptms)
            bestMs += bestCpuMs(reps, [&] { PLX_CHECK(plx::ptm::decodeImage(file).isOk()); });
        std::printf("decode: %.1f MB/s (CPU time, best of %d per file, %s path)\n",
                    mb / bestMs * 1e3, reps, std::string(plx::isaName(plx::activeIsa())).c_str());
        return 0;
    }
    std::fprintf(stderr, "unknown mode '%s'\n", mode.c_str());
    return 2;
}
