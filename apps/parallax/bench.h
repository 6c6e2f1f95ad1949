#pragma once
// Children of `parallax bench`, one source file each; the experiments they run live in
// experiment_<name>.cpp, shared with the demo.

#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "cli.h"

namespace plx::cli {

// The progress of an experiment that reports (done, total) after each step: the bar is made at
// the first step, when the total is known.
class StepProgress {
public:
    explicit StepProgress(std::string label) : mLabel(std::move(label)) {}
    // A callback for run*Experiment; valid while this object lives.
    std::function<void(size_t, size_t)> callback() {
        return [this](size_t, size_t total) {
            if (!mBar) mBar = std::make_unique<Progress>(mLabel, total);
            mBar->step();
        };
    }

private:
    std::string mLabel;
    std::unique_ptr<Progress> mBar;
};

// The start of an experiment command, before any work: its memory check (checkImageMemory of
// `imageBytes`, the experiment's estimate, as "bench NAME at WxH") and its output folder `out`.
// Returns the estimated peak, for memoryJson.
Result<uint64_t> startExperiment(const std::string& name, int width, int height, double imageBytes,
                                 const std::string& out);
// The end of an experiment command: writes `files` and the document (as `jsonName`) into the
// folder `out`, then prints the document (--json) or the human table (printTable(out + "/")).
// Returns the exit code.
int finishExperiment(const std::string& out, bool json, const nlohmann::json& doc,
                     const std::string& jsonName,
                     std::vector<std::pair<std::string, std::string>> files,
                     const std::function<void(const std::string& dir)>& printTable);

Command addBenchPredistort(CLI::App* bench);
Command addBenchStereo(CLI::App* bench);
Command addBenchStream(CLI::App* bench);
Command addBenchWarp(CLI::App* bench);
Command addBenchRemote(CLI::App* bench);

}  // namespace plx::cli
