#include <algorithm>
#include <charconv>
#include <cstdio>
#include <filesystem>
#include <iostream>

#include <fmt/format.h>

#include <plx/core/memory.h>
#include <plx/scene/generators.h>
#include <plx/scene/import.h>

#include "cli.h"

namespace plx::cli {

InputPolicy& inputPolicy() {
    static InputPolicy policy;
    return policy;
}

void addInputOptions(CLI::App& app) {
    // Given anywhere on the command line: subcommands pass options they do not know upwards.
    app.fallthrough();
    InputPolicy& p = inputPolicy();
    app.add_flag("--strict", p.strict,
                 "Treat every warning as an error (e.g. a texture that fails to load)");
    app.add_flag("--allow-external-refs", p.allowExternalRefs,
                 "Let model files refer to files outside their folder");
    app.add_option("--max-pixels", p.maxPixels,
                   "Largest decoded image (textures, ptm encode input) in pixels")
        ->check(CLI::Range(int64_t(1), kMaxDecodedPixels))
        ->capture_default_str();
    // Third-party parsers can crash or hang on hostile files: contained by default.
    app.add_flag("--no-isolate{false}", p.isolate,
                 "Parse model files in this process instead of a limited child process");
    app.add_option("--import-memory", p.importMemoryMb,
                   "Memory limit of the model import's child process in MB")
        ->check(CLI::Range(int64_t(64), int64_t(1) << 20))
        ->capture_default_str();
    app.add_option("--import-seconds", p.importSeconds,
                   "Time limit of the model import's child process in seconds")
        ->check(floatNumber())
        ->check(CLI::Range(0.1, 86400.0))
        ->capture_default_str();
}

Status warn(const std::string& message) {
    if (inputPolicy().strict)
        return errorStatus(ErrorCode::kCorruptData, message + " (an error with --strict)");
    std::fprintf(stderr, "parallax: warning: %s\n", oneLine(message).c_str());
    return Status::ok();
}

int fail(const std::string& message, int code) {
    std::fprintf(stderr, "parallax: error: %s\n", oneLine(message).c_str());
    return code;
}

int fail(const Status& status) { return fail(status.message(), kExitFailure); }

namespace {
Result<float> parseFloat(std::string_view text, const std::string& whole) {
    float v = 0.0f;
    // from_chars takes no leading '+', which strtod and people do ("+0.5").
    const char* begin = text.data() + (text.size() > 1 && text[0] == '+' && text[1] != '-');
    auto [end, ec] = std::from_chars(begin, text.data() + text.size(), v);
    const std::string in = text == whole ? "" : fmt::format(" (in '{}')", whole);
    if (ec == std::errc::result_out_of_range)
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("'{}' is beyond a float's range{}", text, in));
    if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(v))
        return errorStatus(ErrorCode::kInvalidArgument,
                           fmt::format("'{}' is not a finite number{}", text, in));
    return v;
}
}  // namespace

Result<Vec3> parseVec3(const std::string& text) {
    Vec3 out;
    size_t start = 0;
    for (int i = 0; i < 3; ++i) {
        size_t comma = text.find(',', start);
        if ((i < 2) != (comma != std::string::npos))
            return errorStatus(ErrorCode::kInvalidArgument,
                               fmt::format("'{}' is not of the form x,y,z", text));
        std::string_view part(text.data() + start,
                              (comma == std::string::npos ? text.size() : comma) - start);
        auto v = parseFloat(part, text);
        if (!v) return v.status();
        out[i] = *v;
        start = comma + 1;
    }
    return out;
}

CLI::Validator floatNumber() {
    return CLI::Validator(
        [](std::string& text) -> std::string {
            auto v = parseFloat(text, text);
            return v ? std::string() : v.status().message();
        },
        "");  // the option's type (FLOAT) already names it in --help
}

CLI::Validator outputPath(OutputKind kind) {
    return CLI::Validator(
        [kind](std::string& path) -> std::string {
            if (path.empty()) return "an empty path names no output";
            const std::string name = std::filesystem::path(path).filename().string();
            if (kind == OutputKind::kPrefix && (name.empty() || name == "." || name == ".."))
                return fmt::format(
                    "'{}' ends in a folder; the prefix needs a file name "
                    "(e.g. out/office)",
                    printable(path));
            return std::string();
        },
        "");
}

void refuseEmptyValues(CLI::App& app) {
    const CLI::Validator nonEmpty(
        [](std::string& text) -> std::string {
            return text.empty() ? "must not be empty" : std::string();
        },
        "");
    for (CLI::Option* option : app.get_options())
        if (option->get_type_size() != 0) option->check(nonEmpty);
    for (CLI::App* sub : app.get_subcommands({})) refuseEmptyValues(*sub);
}

double shortestDecimal(float v) {
    char text[32];
    const auto written = std::to_chars(text, text + sizeof text, v);
    double d = double(v);
    std::from_chars(text, written.ptr, d);
    return d;
}

Status checkStereoRigNumbers(const StereoRigDesc& rig) {
    auto probe = StereoRig::create(*Camera::create({}), rig);
    return probe ? Status::ok() : probe.status();
}

Result<uint64_t> checkImageMemory(const std::string& what, double imageBytes,
                                  size_t renderedTriangles) {
    if (renderedTriangles > 0)
        imageBytes += kRenderFixedBytes + kRenderBytesPerTriangle * double(renderedTriangles);
    const double estimate = double(residentBytes()) + imageBytes;
    const std::optional<uint64_t> available = availableMemoryBytes();
    constexpr double kGiB = double(1 << 30);
    if (available && imageBytes > double(*available))
        return errorStatus(ErrorCode::kOutOfRange,
                           fmt::format("{} needs about {:.1f} GiB of memory beyond what it "
                                       "holds, {:.1f} GiB is available (memory and swap, cgroup "
                                       "and ulimit limits)",
                                       what, imageBytes / kGiB, double(*available) / kGiB));
    return uint64_t(estimate);
}

Result<double> largestGeneratedTriangles(const std::vector<std::string>& specs) {
    double largest = 0.0;
    for (const std::string& spec : specs) {
        if (!scene::isGeneratorSpec(spec)) continue;
        auto triangles = scene::generatedTriangleBound(spec);
        if (!triangles) return triangles.status();
        largest = std::max(largest, double(*triangles));
    }
    return largest;
}

nlohmann::json memoryJson(uint64_t estimateBytes) {
    constexpr double kMiB = double(1 << 20);
    return {{"memory_estimate_mb", double(estimateBytes) / kMiB},
            {"peak_memory_mb", double(peakResidentBytes()) / kMiB}};
}

std::string jsonText(const nlohmann::json& doc, int indent) {
    return doc.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

void printJson(const nlohmann::json& doc) {
    std::cout << jsonText(doc, 2) << std::endl;
}

Status writeText(const std::string& path, const std::string& text) {
    return writeFileBytes(path, {reinterpret_cast<const uint8_t*>(text.data()), text.size()});
}

Status createOutputFolder(const std::string& dir) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec)
        return errorStatus(ErrorCode::kIoError,
                           fmt::format("cannot create directory '{}': {}", dir, ec.message()));
    return Status::ok();
}

Status ensureParentDirectory(const std::string& prefix) {
    std::filesystem::path parent = std::filesystem::path(prefix).parent_path();
    return parent.empty() ? Status::ok() : createOutputFolder(parent.string());
}

}  // namespace plx::cli

#include <unistd.h>

namespace plx::cli {

Progress::Progress(std::string label, size_t total)
    : mLabel(std::move(label)), mTotal(std::max<size_t>(total, 1)), mTerminal(isatty(2)) {}

Progress::~Progress() {
    if (mDrawn) std::fprintf(stderr, "\n");
}

void Progress::step(size_t n) {
    mDone = std::min(mTotal, mDone + n);
    if (!mTerminal || mClock.elapsedMs() < 1000.0) return;
    constexpr int kWidth = 30;
    int filled = int(double(mDone) / double(mTotal) * kWidth);
    std::fprintf(stderr, "\r%s [%s%s] %zu/%zu", mLabel.c_str(), std::string(size_t(filled), '#').c_str(),
                 std::string(size_t(kWidth - filled), '.').c_str(), mDone, mTotal);
    std::fflush(stderr);
    mDrawn = true;
}

}  // namespace plx::cli
