// parallax: the command-line program. One source file per subcommand; see commands.h.

#include "commands.h"

#include <algorithm>
#include <new>

#include <fmt/format.h>

#include <plx/core/cpu.h>

namespace {

// The input pre-checks should make running out of memory unreachable; should one be missed, the
// user still gets one line naming the problem instead of a bare "std::bad_alloc" and an abort.
int runGuarded(const plx::cli::Command& c) {
    try {
        return c.run();
    } catch (const std::bad_alloc&) {
        return plx::cli::fail(
            fmt::format("out of memory while running '{}' (the input asks for "
                        "more memory than this machine has)",
                        c.app->get_name()));
    }
}

}  // namespace

int main(int argc, char** argv) {
    using namespace plx::cli;
    CLI::App app{"Parallax: render complex 3D scenes for stereo, remote and curved displays by "
                 "reusing visibility, pixels, reference images and textures."};
    app.set_version_flag("--version", "parallax 0.1.0\n" + plx::isaSummary());
    app.require_subcommand(1);
    app.footer("Run 'parallax COMMAND --help' for a command's options and an example.");
    addInputOptions(app);

    std::vector<Command> commands = {
        registerRender(app),
        registerStereo(app),
        registerWarp(app),
        registerServe(app),
        registerClient(app),
        registerStream(app),
        registerDemo(app),
        registerInfo(app),
        registerPtm(app),
        registerPredistort(app),
        registerBench(app),
    };
    refuseEmptyValues(app);
    if (std::string problem = plx::isaEnvironmentError(); !problem.empty())
        return fail(problem, kExitUsage);
    if (argc > 1 && argv[1][0] != '-' &&
        std::none_of(commands.begin(), commands.end(),
                     [&](const Command& c) { return c.app->get_name() == argv[1]; }))
        return fail(fmt::format("unknown command '{}' (see parallax --help)", argv[1]), kExitUsage);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help and --version print and succeed; a usage error is one line, as every error is.
        if (e.get_exit_code() == 0) return app.exit(e);
        return fail(e.what(), kExitUsage);
    }
    for (const Command& c : commands)
        if (c.app->parsed()) return runGuarded(c);
    return fail("no command given", kExitUsage);
}
