// parallax bench <experiment>: the papers' experiments as CSV, JSON and SVG plots. A plain
// dispatcher; each experiment lives in its own bench_<name>.cpp.
//
//   bench predistort   Bimber et al. Table 1 and Figs. 8-10 (uniform vs adaptive warp meshes)
//   bench stereo       Heo, Jung, Wohn Table 1 and Fig. 17 (full vs P-buffer stereo pairs), with
//                      the reproject method of Fu, Bao, Peng and its paper's timing table
//   bench warp         Mark, Bishop, McMillan: stale, timewarp and warp against the RTT
//   bench remote       the same system over real sockets: warp vs video vs timewarp, RTT and
//                      bandwidth emulated on loopback
//   bench stream       Marvie, Bouatouch section 7 (texture streaming walks, frame time against a
//                      full-resolution baseline) and the ACH allocation against LRU and equal split

#include "bench.h"

#include <fmt/format.h>

#include "commands.h"

namespace plx::cli {

Result<uint64_t> startExperiment(const std::string& name, int width, int height, double imageBytes,
                                 const std::string& out) {
    auto memory = checkImageMemory(fmt::format("{} at {}x{}", name, width, height), imageBytes);
    if (!memory) return memory.status();
    PLX_RETURN_IF_ERROR(createOutputFolder(out));
    return memory;
}

int finishExperiment(const std::string& out, bool json, const nlohmann::json& doc,
                     const std::string& jsonName,
                     std::vector<std::pair<std::string, std::string>> files,
                     const std::function<void(const std::string& dir)>& printTable) {
    files.emplace_back(jsonName, jsonText(doc, 2));
    for (const auto& [name, text] : files)
        if (Status s = writeText(out + "/" + name, text); !s) return fail(s);
    if (json)
        printJson(doc);
    else
        printTable(out + "/");
    return kExitOk;
}

Command registerBench(CLI::App& app) {
    CLI::App* bench = app.add_subcommand("bench", "Run the papers' experiments (CSV, JSON, SVG)");
    bench->require_subcommand(1);
    bench->footer(
        "Example: parallax bench warp --quick --out out/bench_warp   "
        "(each experiment's --help names its table, plots and JSON)");
    std::vector<Command> children = {addBenchStereo(bench), addBenchPredistort(bench),
                                     addBenchWarp(bench), addBenchRemote(bench),
                                     addBenchStream(bench)};
    return {bench, [children] {
                for (const Command& c : children)
                    if (c.app->parsed()) return c.run();
                return fail("bench needs an experiment", kExitUsage);
            }};
}

}  // namespace plx::cli
