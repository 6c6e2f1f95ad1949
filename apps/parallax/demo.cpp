// parallax demo: the main job. Builds the procedural scenes, renders them, and writes a report
// with images and plots to out/demo/index.html. Needs no arguments and no network.

#include <fmt/format.h>

#include "commands.h"
#include "demo.h"

namespace plx::cli {
namespace {

struct DemoArgs {
    std::string out = "out/demo";
    int threads = 0;
    bool quick = false;
    bool json = false;
};

int runDemo(const DemoArgs& a) {
    if (Status s = createOutputFolder(a.out); !s) return fail(s);
    HtmlReport report("Parallax demo");
    nlohmann::json summary = nlohmann::json::object();
    DemoContext ctx{a.out, &report, &summary, a.threads, a.quick};
    report.paragraph(
        "Parallax renders complex 3D scenes for stereo, remote and curved displays "
        "by reusing what was already computed. Every number below was measured "
        "while this page was generated.");
    using Section = Status (*)(DemoContext&);
    for (Section section :
         {Section(demoRasterSection), Section(demoStereoSection), Section(demoWarpSection),
          Section(demoRemoteSection), Section(demoDisplaySection), Section(demoPtmSection),
          Section(demoStreamSection)}) {
        if (Status s = section(ctx); !s) return fail(s);
    }
    std::string index = a.out + "/index.html";
    if (Status s = report.write(index); !s) return fail(s);
    if (a.json) {
        summary["report"] = index;
        printJson(summary);
    } else {
        fmt::print("wrote {}\n", index);
    }
    return kExitOk;
}

}  // namespace

Command registerDemo(CLI::App& app) {
    auto a = std::make_shared<DemoArgs>();
    CLI::App* sub = app.add_subcommand("demo", "Run the demo and write an HTML report");
    sub->footer("Example: parallax demo   (then open out/demo/index.html)");
    sub->add_option("--out", a->out, "Report folder")
        ->capture_default_str()
        ->check(outputPath(OutputKind::kFolder));
    sub->add_option("--threads", a->threads, "Worker threads (0: all cores)")
        ->capture_default_str();
    sub->add_flag("--quick", a->quick, "Small sizes and few frames (for tests)");
    sub->add_flag("--json", a->json, "Print the headline numbers as JSON on stdout");
    return {sub, [a] { return runDemo(*a); }};
}

}  // namespace plx::cli
