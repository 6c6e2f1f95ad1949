#pragma once
// Shared pieces of the parallax command line: subcommand registration, argument parsing helpers,
// one-line errors and JSON output.

#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <plx/core/core.h>
#include <plx/core/image_io.h>
#include <plx/core/stereo_rig.h>

namespace plx::cli {

// Exit codes: 0 success, 1 the work failed (bad input file, I/O), 2 bad command-line usage.
constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitUsage = 2;

// Each subcommand file defines a register function that adds its CLI11 subcommand to the app
// and returns it with the function that runs it after parsing (giving the exit code).
struct Command {
    CLI::App* app = nullptr;
    std::function<int()> run;
};

// How every command treats its input files, from the options any command accepts (main.cpp):
// --strict, --allow-external-refs, --max-pixels, --no-isolate, --import-memory, --import-seconds.
struct InputPolicy {
    bool strict = false;                    // every warning is an error
    bool allowExternalRefs = false;         // models may refer to files outside their folder
    int64_t maxPixels = kDefaultMaxPixels;  // decoded images: textures, `ptm encode` inputs
    // Model files are parsed in a child process under these limits (scene::IsolationLimits).
    bool isolate = true;
    int64_t importMemoryMb = 4096;
    double importSeconds = 60.0;
};
InputPolicy& inputPolicy();
void addInputOptions(CLI::App& app);

// A warning on stderr ("parallax: warning: <message>"), or with --strict the failure it becomes.
Status warn(const std::string& message);

// Prints "parallax: error: <message>" on stderr and returns kExitFailure (or the given code).
int fail(const std::string& message, int code = kExitFailure);
int fail(const Status& status);

// "x,y,z" -> Vec3; "WxH" -> (W, H). Errors name the offending text.
Result<Vec3> parseVec3(const std::string& text);
inline Result<IVec2> parseSize(const std::string& text) {
    return parseImageSize(text);
}

// A validator for options read into a float (->check(floatNumber())): refuses what is no finite
// number or lies beyond a float's range ("'1e300' is beyond a float's range"), which CLI11 would
// otherwise read as infinity and the later range check report as "inf".
CLI::Validator floatNumber();

// A validator for --out (->check(outputPath(...))): a folder or a prefix must not be empty (the
// current folder, unasked), and a prefix must end in a file name: "out/" would write the hidden
// files out/.color.png and the like.
enum class OutputKind { kFolder, kPrefix };
CLI::Validator outputPath(OutputKind kind);

// Adds to every option of `app` and its subcommands that takes a value, positionals included, a
// check that refuses an empty one: CLI11 reads '' as the type's zero or as "not given" (--threads
// '' ran with every core, serve --seconds '' for ever, stream walk '' read /root.json).
void refuseEmptyValues(CLI::App& app);

// A float as the double of its shortest decimal form, for --json: 0.065f is 0.06499999761581421
// as a double, and nlohmann::json prints that.
double shortestDecimal(float v);

// A stereo rig's numbers (separation, convergence) checked as usage, before any scene is loaded:
// the rig built around a throwaway default camera, whose errors name the bad number.
Status checkStereoRigNumbers(const StereoRigDesc& rig);

// Bytes of a size given in MiB on the command line (--budget 1.5).
inline uint64_t mebibytes(double mb) { return uint64_t(std::llround(mb * double(1 << 20))); }

// Work whose memory grows with the image (render, stereo, warp, client, stream walk), checked
// before it starts: its peak is estimated as what the process holds now (the scene loaded) plus
// `imageBytes`, the command's measured bytes per pixel times its pixels and what else it will
// allocate (a server's queue, the reprojection's search structures), plus the renderer's memory
// for the `renderedTriangles` of the scene it renders (kRenderFixedBytes and
// kRenderBytesPerTriangle; none when 0). Refuses, naming `what`, that share and what is
// available, when the share exceeds what availableMemoryBytes() says the process can still take,
// where the kernel would otherwise end it without a message. Returns the estimated peak in bytes.
Result<uint64_t> checkImageMemory(const std::string& what, double imageBytes,
                                  size_t renderedTriangles = 0);

// What the renderer allocates at its first frame of a scene, beside the images: the growth of the
// peak beyond what the process held at the check, at 64x64 on office:16, 64 and 280 (58k to 1M
// triangles), fits 1.0 MB + 29.3 bytes a triangle for render and stereo, 1.6 MB + 31.9 for warp.
// Rounded up.
inline constexpr double kRenderFixedBytes = 2 << 20;
inline constexpr double kRenderBytesPerTriangle = 34.0;
// What a generated scene holds a triangle: 81.7 bytes (the growth of the resident size from
// office:16 to office:280). Rounded up.
inline constexpr double kGeneratedSceneBytesPerTriangle = 88.0;

// The triangles of the largest generated scene among `specs` (scene::generatedTriangleBound),
// for experiments that load their scenes after their memory check. Model files count none:
// their import runs in a child process that --import-memory bounds. Errors: a bad generator spec.
Result<double> largestGeneratedTriangles(const std::vector<std::string>& specs);

// What the reproject stereo method's search structures (prepareReprojection) hold per scene
// triangle: the growth of the peak over the full method's at 64x64, on office:64 and office:280
// alike, is 96-97 for the box hierarchy and 270-271 with the BSP tree (its fragments per triangle
// vary by scene; BspConfig::maxFragmentsPerTriangle bounds them). Rounded up.
inline constexpr double kReprojectBoxesBytesPerTriangle = 104.0;
inline constexpr double kReprojectBspBytesPerTriangle = 288.0;

// The estimate checkImageMemory gave and the peak the process reached, in MiB, for --json:
// {"memory_estimate_mb": ..., "peak_memory_mb": ...}.
nlohmann::json memoryJson(uint64_t estimateBytes);

// "1 frame", "2 frames": a count and its noun, in the plural unless the count is one ("mesh":
// "meshes", "vertex": "vertices").
inline std::string counted(uint64_t count, const std::string& noun) {
    if (count == 1) return "1 " + noun;
    if (noun == "vertex") return std::to_string(count) + " vertices";
    const bool sibilant = noun.ends_with("sh") || noun.ends_with("ch") || noun.ends_with('s');
    return std::to_string(count) + " " + noun + (sibilant ? "es" : "s");
}

// A figure that may not exist (no set sent, quality never reached, no ping answered yet), for
// --json: null where there is none, so that no script reads a -1 or 0 as a measurement.
template <class T>
nlohmann::json valueOrNull(bool exists, T value) {
    return exists ? nlohmann::json(value) : nlohmann::json();
}
template <class T>
nlohmann::json valueOrNull(const std::optional<T>& value) {
    return value ? nlohmann::json(*value) : nlohmann::json();
}
// The same for a table or CSV cell: the figure in `form`, or `none` where nothing was measured.
inline std::string figureOrEmpty(const std::optional<double>& value,
                                 fmt::format_string<double> form, const std::string& none = "") {
    return value ? fmt::format(form, double{*value}) : none;
}

// JSON has no infinity: identical images (infinite PSNR) are reported as this many dB.
inline constexpr double kIdenticalPsnrDb = 99.0;

// The document's text, bytes that are not UTF-8 (a peer's or a file's, quoted back) as U+FFFD:
// nlohmann's dump throws on them, which would end the command without a word.
std::string jsonText(const nlohmann::json& doc, int indent = -1);
// Writes the JSON document (jsonText) as the only thing on stdout.
void printJson(const nlohmann::json& doc);

// Writes text to a file; the error names the file.
Status writeText(const std::string& path, const std::string& text);

// An output folder, created with its parents; the error ("cannot create directory ...") names it.
Status createOutputFolder(const std::string& dir);
// Creates the parent directory of an output prefix ("out/x" -> "out/").
Status ensureParentDirectory(const std::string& prefix);

}  // namespace plx::cli

namespace plx::cli {

// A progress bar on stderr, drawn only when stderr is a terminal and the work has run for more
// than a second (so scripted runs and quick commands print nothing).
class Progress {
public:
    Progress(std::string label, size_t total);
    ~Progress();
    void step(size_t n = 1);

private:
    std::string mLabel;
    size_t mTotal, mDone = 0;
    bool mTerminal;
    bool mDrawn = false;
    Stopwatch mClock;
};

}  // namespace plx::cli
