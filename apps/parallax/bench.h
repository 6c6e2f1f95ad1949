#pragma once
// Children of `parallax bench`, one source file each, and the plots they share with the demo.

#include <plx/stereo/experiment.h>

#include "cli.h"
#include "report.h"

namespace plx::cli {

Command addBenchPredistort(CLI::App* bench);

// The cone-shaped Virtual Showcase of examples/displays/cone_showcase.json, built in so that the
// benchmark and the demo run from any directory.
extern const char* const kConeShowcaseJson;
Command addBenchStereo(CLI::App* bench);

// Fig. 17 of Heo, Jung, Wohn from an experiment: (a) first-eye time, (b) second-eye time,
// (c) pair time, each for both methods against the polygon count; plus the pair speedup.
// Returns (file name, SVG) pairs.
std::vector<std::pair<std::string, std::string>> stereoPlots(
    const std::vector<stereo::StereoExperimentRow>& rows);

}  // namespace plx::cli
