// parallax ptm encode|decode|info|verify: progressive texture maps (Marvie & Bouatouch section 4).

#include <filesystem>

#include <fmt/format.h>

#include <plx/core/image_io.h>
#include <plx/ptm/ptm.h>

#include "commands.h"

namespace plx::cli {
namespace {

struct PtmArgs {
    std::string input;
    std::string output;
    std::string against;
    int level = -1;
    int lowest = 1;
    bool raw = false;
    std::string coder;      // --coder name, overrides --raw
    int shapeEighths = -1;  // --shape-eighths (coder rans)
    bool json = false;
    bool partial = false;  // ptm info: describe a prefix (a download in progress)
};

// A decoder's error with the file it read: "wall.ptm: PTM: file truncated in level 5 (...)".
int failReading(const PtmArgs& a, const Status& s) {
    return fail(fmt::format("{}: {}", printable(a.input, kMaxMessageChars), s.message()));
}

// -o naming the input (or a link to it) would replace the only copy before anything is read
// back; refused before the input is read.
Status checkOutputIsNotInput(const PtmArgs& a) {
    std::error_code ec;
    if (std::filesystem::equivalent(a.input, a.output, ec))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("-o {} is the input file; write to another file",
                                       printable(a.output, kMaxMessageChars)));
    return Status::ok();
}

int runEncode(const PtmArgs& a) {
    if (Status s = checkOutputIsNotInput(a); !s) return fail(s.message(), kExitUsage);
    auto image = readImage(a.input, inputPolicy().maxPixels);
    if (!image) return fail(image.status());
    ptm::EncodeConfig cfg;
    cfg.lowestMaxSide = a.lowest;
    cfg.shapeEighths = a.shapeEighths;
    cfg.coder = a.raw || a.coder == ptm::coderName(ptm::Coder::kRaw) ? ptm::Coder::kRaw
                                                                     : ptm::Coder::kRans;
    Stopwatch watch;
    auto file = ptm::encode(*image, cfg);
    if (!file) return fail(file.status());
    const double ms = watch.elapsedMs();
    if (Status s = writeFileBytes(a.output, *file); !s) return fail(s);
    const size_t raw = image->bytes.size();
    if (a.json) {
        printJson({{"input", a.input}, {"output", a.output}, {"width", image->width},
                   {"height", image->height}, {"components", image->channels},
                   {"bytes", file->size()}, {"raw_bytes", raw}, {"encode_ms", ms}});
    } else {
        fmt::print("{}: {}x{}x{} -> {} ({} bytes, {:.3f} of raw, {:.1f} ms)\n", a.input,
                   image->width, image->height, image->channels, a.output, file->size(),
                   double(file->size()) / double(raw), ms);
    }
    return kExitOk;
}

int runDecode(const PtmArgs& a) {
    if (Status s = checkOutputIsNotInput(a); !s) return fail(s.message(), kExitUsage);
    auto bytes = readFileBytes(a.input);
    if (!bytes) return fail(bytes.status());
    auto header = ptm::parseHeader(*bytes);
    if (!header) return failReading(a, header.status());
    const int k = a.level < 0 ? header->levelCount - 1 : a.level;
    if (k >= header->levelCount)
        return fail(fmt::format("--level {} outside 0..{} (0 is the smallest)", k,
                                header->levelCount - 1),
                    kExitUsage);
    auto image = ptm::decodeLevel(*bytes, k);
    if (!image) return failReading(a, image.status());
    if (Status s = writePng(a.output, *image); !s) return fail(s);
    if (a.json)
        printJson({{"input", a.input}, {"output", a.output}, {"level", k},
                   {"width", image->width}, {"height", image->height}});
    else
        fmt::print("{}: level {} ({}x{}) -> {}\n", a.input, k, image->width, image->height,
                   a.output);
    return kExitOk;
}

// "levels 0..k complete" or "no level complete" for a prefix of size bytes.
std::string completeLevels(const ptm::Header& h, uint64_t size) {
    int complete = 0;
    while (complete < h.levelCount) {
        const ptm::ByteRange r = ptm::levelByteRange(h, complete);
        if (r.offset + r.size > size) break;
        ++complete;
    }
    return complete == 0
               ? "no level complete"
               : fmt::format("levels 0..{} of 0..{} complete", complete - 1, h.levelCount - 1);
}

int runInfo(const PtmArgs& a) {
    auto bytes = readFileBytes(a.input);
    if (!bytes) return fail(bytes.status());
    auto h = ptm::parseHeader(*bytes);
    if (!h) return failReading(a, h.status());
    // A prefix is a valid download in progress, but info describes a file: say what is missing.
    if (bytes->size() < h->fileBytes() && !a.partial)
        return fail(
            fmt::format("{} is truncated: {} of the {} bytes its header declares ({}; "
                        "--partial describes a prefix)",
                        a.input, bytes->size(), h->fileBytes(), completeLevels(*h, bytes->size())));
    const double raw = double(h->width) * h->height * h->components;
    nlohmann::json levels = nlohmann::json::array();
    uint64_t rawChain = 0;
    for (int k = 0; k < h->levelCount; ++k) {
        const ptm::LevelSize s = h->levelSize(k);
        const ptm::ByteRange r = ptm::levelByteRange(*h, k);
        const uint64_t levelRaw = uint64_t(s.width) * s.height * h->components;
        rawChain += levelRaw;
        nlohmann::json level = {{"level", k},
                                {"width", s.width},
                                {"height", s.height},
                                {"offset", r.offset},
                                {"bytes", r.size},
                                {"ratio", double(levelRaw) / double(r.size)},
                                {"complete", r.offset + r.size <= bytes->size()}};
        // Coder rans: how the encoder coded the group (its mode byte), when the file holds it.
        if (h->coder == ptm::Coder::kRans && r.offset < bytes->size()) {
            const uint8_t mode = (*bytes)[r.offset];
            level["stored"] = mode == ptm::kStoredGroupMode;
            if (mode != ptm::kStoredGroupMode && k > 0) level["shape_eighths"] = int(mode);
        }
        levels.push_back(level);
    }
    const uint64_t total = h->fileBytes();
    nlohmann::json doc = {{"file", a.input}, {"width", h->width}, {"height", h->height},
                          {"components", h->components}, {"levels", h->levelCount},
                          {"lowest", {h->lowest.width, h->lowest.height}},
                          {"coder", ptm::coderName(h->coder)}, {"bytes", total},
                          {"file_complete", bytes->size() == total},
                          {"ratio_vs_base", raw / double(total)},
                          {"ratio_vs_mip_chain", double(rawChain) / double(total)},
                          {"level_groups", levels}};
    if (a.json) {
        printJson(doc);
        return kExitOk;
    }
    fmt::print("{}: {}x{}x{}, {} levels (lowest {}x{}), coder {}, {} bytes{}\n", a.input, h->width,
               h->height, h->components, h->levelCount, h->lowest.width, h->lowest.height,
               ptm::coderName(h->coder), total,
               bytes->size() < total ? fmt::format(" (a prefix of {} bytes: {})", bytes->size(),
                                                   completeLevels(*h, bytes->size()))
                                     : "");
    fmt::print("compression: {:.2f}:1 vs the base level, {:.2f}:1 vs the raw mip chain\n",
               raw / double(total), double(rawChain) / double(total));
    for (const auto& l : levels) {
        const std::string how = !l.contains("stored")     ? ""
                                : l["stored"].get<bool>() ? ", stored"
                                : l.contains("shape_eighths")
                                    ? fmt::format(", shape {}/8", int(l["shape_eighths"]))
                                    : ", modelled";
        fmt::print("  level {:2}: {:5}x{:<5} bytes [{}, {}) {:8} ({:.2f}:1{}){}\n", int(l["level"]),
                   int(l["width"]), int(l["height"]), uint64_t(l["offset"]),
                   uint64_t(l["offset"]) + uint64_t(l["bytes"]), uint64_t(l["bytes"]),
                   double(l["ratio"]), how, l["complete"].get<bool>() ? "" : ", missing");
    }
    return kExitOk;
}

int runVerify(const PtmArgs& a) {
    auto bytes = readFileBytes(a.input);
    if (!bytes) return fail(bytes.status());
    auto levels = ptm::decodeAllLevels(*bytes);
    if (!levels) return failReading(a, levels.status());
    std::string against = "not compared";
    if (!a.against.empty()) {
        auto original = readImage(a.against, inputPolicy().maxPixels);
        if (!original) return fail(original.status());
        if (!(levels->back() == *original))
            return fail(fmt::format("{} does not decode to {} exactly", a.input, a.against));
        auto chain = ptm::buildMipChain(*original, int(levels->size()));
        for (size_t k = 0; k < chain.size(); ++k)
            if (!((*levels)[k] == chain[k]))
                return fail(fmt::format("level {} differs from the box-filtered mip", k));
        against = "bit-exact, every level";
    }
    if (a.json)
        printJson({{"file", a.input}, {"ok", true}, {"levels", levels->size()},
                   {"against", against}});
    else
        fmt::print("{}: ok, {} levels decoded, checksums good; original: {}\n", a.input,
                   levels->size(), against);
    return kExitOk;
}

}  // namespace

Command registerPtm(CLI::App& app) {
    auto args = std::make_shared<PtmArgs>();
    CLI::App* sub = app.add_subcommand("ptm", "Progressive texture maps: encode, decode, inspect");
    sub->require_subcommand(1);
    sub->footer("Example: parallax ptm encode wall.png -o wall.ptm && parallax ptm info wall.ptm");
    CLI::App* enc = sub->add_subcommand("encode", "Encode a PNG or JPEG image to PTM");
    enc->add_option("input", args->input, "Image file (PNG or JPEG)")->required();
    enc->add_option("-o,--output", args->output, "Output .ptm file")->required();
    enc->add_option("--lowest", args->lowest, "Largest side of the smallest stored level")
        ->check(CLI::Range(1, 1 << 15));
    auto* rawFlag =
        enc->add_flag("--raw", args->raw, "Store the planes uncompressed (the paper's layout)");
    enc->add_option("--coder", args->coder,
                    "rans (the default: context-modelled, 32 rANS states) or raw (uncompressed, "
                    "for debugging)")
        ->check(CLI::IsMember({ptm::coderName(ptm::Coder::kRans),
                               ptm::coderName(ptm::Coder::kRaw)}))
        ->excludes(rawFlag);
    enc->add_option("--shape-eighths", args->shapeEighths,
                    "Coder rans: weight of the detail above in the upper pixels' shapes, 0..4 "
                    "eighths, for every level (default: tried per level, about 3x slower)")
        ->check(CLI::Range(0, ptm::kMaxShapeEighths));
    enc->add_flag("--json", args->json, "Machine-readable output on stdout");
    enc->footer("Example: parallax ptm encode wall.jpg -o wall.ptm --lowest 4");
    CLI::App* dec = sub->add_subcommand("decode", "Decode one level of a PTM to PNG");
    dec->add_option("input", args->input, "PTM file (a prefix holding the level suffices)")
        ->required();
    dec->add_option("-o,--output", args->output, "Output PNG")->required();
    dec->add_option("--level", args->level, "Stored level, 0 = smallest (default: full size)")
        ->check(CLI::Range(0, 63));
    dec->add_flag("--json", args->json, "Machine-readable output on stdout");
    dec->footer("Example: parallax ptm decode wall.ptm --level 3 -o wall_l3.png");
    CLI::App* info = sub->add_subcommand("info", "Levels, byte ranges, coder and ratios");
    info->add_option("input", args->input, "PTM file")->required();
    info->add_flag("--json", args->json, "Machine-readable output on stdout");
    info->add_flag("--partial", args->partial,
                   "Describe a prefix of a file (a download in progress) instead of refusing it "
                   "as truncated");
    info->footer("Example: parallax ptm info wall.ptm --json");
    CLI::App* ver = sub->add_subcommand("verify", "Decode every level and check checksums");
    ver->add_option("input", args->input, "PTM file")->required();
    ver->add_option("--against", args->against, "Original image: require bit-exact levels");
    ver->add_flag("--json", args->json, "Machine-readable output on stdout");
    ver->footer("Example: parallax ptm verify wall.ptm --against wall.png");
    return {sub, [args, enc, dec, info, ver]() -> int {
                if (enc->parsed()) return runEncode(*args);
                if (dec->parsed()) return runDecode(*args);
                if (info->parsed()) return runInfo(*args);
                if (ver->parsed()) return runVerify(*args);
                return fail("ptm: no subcommand given", kExitUsage);
            }};
}

}  // namespace plx::cli
