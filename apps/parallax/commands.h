#pragma once
// The subcommands of parallax, one source file each.

#include "cli.h"

namespace plx::cli {

Command registerInfo(CLI::App& app);
Command registerRender(CLI::App& app);
Command registerDemo(CLI::App& app);
Command registerPtm(CLI::App& app);
Command registerPredistort(CLI::App& app);
Command registerBench(CLI::App& app);
Command registerStereo(CLI::App& app);
Command registerWarp(CLI::App& app);
Command registerStream(CLI::App& app);
Command registerServe(CLI::App& app);
Command registerClient(CLI::App& app);
// Adds `stream walk` under the stream command; its run falls back to `inner` for the others.
Command registerStreamWalk(CLI::App* stream, Command inner);

}  // namespace plx::cli
