#pragma once
// Children of `parallax bench`, one source file each; the experiments they run live in
// experiment_<name>.cpp, shared with the demo.

#include "cli.h"

namespace plx::cli {

Command addBenchPredistort(CLI::App* bench);
Command addBenchStereo(CLI::App* bench);
Command addBenchStream(CLI::App* bench);
Command addBenchWarp(CLI::App* bench);

}  // namespace plx::cli
