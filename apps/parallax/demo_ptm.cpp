// The demo's progressive-texture section (Marvie, Bouatouch, section 4): a texture coded as a
// PTM, its levels decoded as their groups arrive (smallest first), the bytes each level adds,
// and the whole file against the PNG of the base level alone.

#include <algorithm>
#include <filesystem>
#include <span>

#include <fmt/format.h>

#include <plx/core/image_io.h>
#include <plx/core/timing.h>
#include <plx/ptm/ptm.h>

#include "demo.h"

namespace plx::cli {
namespace {

// The level scaled by pixel repetition to at least `side` pixels wide, so that a row of levels
// shows what each one holds at the same displayed size.
ByteImage enlarged(const ByteImage& level, int side) {
    const int f = std::max(1, side / std::max(1, level.width));
    ByteImage out{level.width * f, level.height * f, level.channels, {}};
    out.bytes.resize(out.rowBytes() * size_t(out.height));
    for (int y = 0; y < out.height; ++y)
        for (int x = 0; x < out.width; ++x)
            std::copy_n(level.pixel(x / f, y / f), level.channels, out.pixel(x, y));
    return out;
}

// A Sponza texture from the shared data when present, else the office:4 render that the
// rasterizer section wrote (in quick runs too); quick runs (tests) take its first mip level of
// at most 128 pixels.
Result<std::pair<ByteImage, std::string>> demoTexture(const DemoContext& ctx) {
    const std::string name = "6047387724914829168.jpg";
    const std::string shared = std::string(PLX_SHARED_DATA_DIR) + "/textures/sponza/" + name;
    std::pair<ByteImage, std::string> out;
    if (std::filesystem::exists(shared)) {
        auto image = readImage(shared);
        if (!image) return image.status();
        out = {std::move(*image), "The Sponza texture " + name};
    } else {
        auto image = readImage(ctx.outDir + "/office4.color.png");
        if (!image) return image.status();
        out = {std::move(*image), "The office:4 render above (no Sponza textures in " +
                                      std::string(PLX_SHARED_DATA_DIR) + ")"};
    }
    if (ctx.quick)
        while (std::max(out.first.width, out.first.height) > 128)
            out.first = ptm::boxReduce(out.first);
    return out;
}

}  // namespace

Status demoPtmSection(DemoContext& ctx) {
    HtmlReport& rep = *ctx.report;
    auto texture = demoTexture(ctx);
    if (!texture) return texture.status();
    const ByteImage& image = texture->first;
    Stopwatch clock;
    auto file = ptm::encode(image, ptm::EncodeConfig{});
    if (!file) return file.status();
    const double encodeMs = clock.elapsedMs();
    auto png = encodePng(image, 9);
    if (!png) return png.status();

    // The client's side: each group decoded as soon as its bytes are there.
    auto decoder = ptm::ProgressiveDecoder::create(*file);
    if (!decoder) return decoder.status();
    const ptm::Header& header = decoder->header();
    const int levels = header.levelCount;
    const int firstShown = std::max(0, levels - 5);
    std::vector<std::pair<std::string, std::string>> shown;
    std::vector<std::vector<std::string>> rows;
    PlotSeries cumulative{"PTM, levels so far", {}},
        pngLine{"PNG of the base level (libpng 9)", {}};
    uint64_t bytesSoFar = header.headerBytes();
    double decodeMs = 0;
    for (int k = 0; k < levels; ++k) {
        const ptm::ByteRange r = ptm::levelByteRange(header, k);
        clock.restart();
        PLX_RETURN_IF_ERROR(decoder->addGroup(std::span(*file).subspan(r.offset, r.size)));
        const double ms = clock.elapsedMs();
        decodeMs += ms;
        bytesSoFar += r.size;
        const ByteImage& level = decoder->level(k);
        cumulative.points.emplace_back(level.width, double(bytesSoFar) / 1024.0);
        rows.push_back({fmt::format("{}", k), fmt::format("{}x{}", level.width, level.height),
                        fmt::format("{}", r.size), fmt::format("{}", bytesSoFar),
                        fmt::format("{:.1f}%", 100.0 * double(bytesSoFar) / double(file->size())),
                        fmt::format("{:.2f}", ms)});
        if (k < firstShown) continue;
        const std::string name = fmt::format("ptm_level{}.png", k);
        PLX_RETURN_IF_ERROR(writePng(ctx.outDir + "/" + name, enlarged(level, 256)));
        shown.push_back({name, fmt::format("level {}: {}x{}, after {} bytes ({:.1f}%)", k,
                                           level.width, level.height, bytesSoFar,
                                           100.0 * double(bytesSoFar) / double(file->size()))});
    }
    // Each level must be the box-filtered mip (eq. 1) of the texture, the last the texture.
    const std::vector<ByteImage> mips = ptm::buildMipChain(image, levels);
    for (int k = 0; k < levels; ++k)
        if (decoder->level(k) != mips[size_t(k)])
            return errorStatus(ErrorCode::kInternal,
                               fmt::format("PTM demo: decoded level {} differs from the mip", k));
    const double pngKb = double(png->size()) / 1024.0;
    pngLine.points = {{cumulative.points.front().first, pngKb},
                      {cumulative.points.back().first, pngKb}};

    const double mb = double(image.bytes.size()) / 1e6;
    rep.heading("Progressive texture maps (Marvie and Bouatouch)");
    rep.paragraph(fmt::format(
        "{}, {}x{} with {} components, coded as a PTM ({}): {} levels, the smallest first, each "
        "group decodable given only the levels below it (the box-filter residuals of eq. 1 and "
        "three of the four pixels of each block; eq. 3 gives the fourth). The whole file is {} "
        "bytes, {:.3f}x the PNG of the base level alone ({} bytes) and {:.3f}x the raw pixels; "
        "every level decoded equal to its box-filtered mip. Encode {:.0f} ms; decode of all "
        "groups {:.1f} ms ({:.0f} MB/s, one thread, this run). The enlarged levels below show "
        "what a client has after each group's bytes.",
        texture->second, image.width, image.height, image.channels, ptm::coderName(header.coder),
        levels, file->size(), double(file->size()) / double(png->size()), png->size(),
        double(file->size()) / double(image.bytes.size()), encodeMs, decodeMs,
        mb / std::max(decodeMs / 1e3, 1e-9)));
    rep.images(shown);
    rep.raw("<div class='row'>" +
            svgLinePlot({"Bytes a client has fetched, level by level", "level width (pixels)",
                         "KiB", true, true},
                        {cumulative, pngLine}) +
            "</div>");
    rep.table({"level", "size", "group bytes", "bytes so far", "of the file", "decode ms"}, rows);
    (*ctx.summary)["ptm"] = {
        {"texture", texture->second}, {"coder", ptm::coderName(header.coder)},
        {"levels", levels},           {"bytes", file->size()},
        {"png_bytes", png->size()},   {"ratio_to_png", double(file->size()) / double(png->size())},
        {"encode_ms", encodeMs},      {"decode_ms", decodeMs}};
    return Status::ok();
}

}  // namespace plx::cli
