// plx_display_experiment DISPLAY.json OUT_PREFIX [threads] [container]: runs the Table 1
// experiment for the display's default viewer and the built-in exhibit (grid B limited by the
// container: hull by default, obb or none); writes OUT_PREFIX.json and OUT_PREFIX.csv.

#include <cstdio>
#include <string>

#include <plx/core/image_io.h>
#include <plx/display/display_json.h>
#include <plx/display/predistort.h>

int main(int argc, char** argv) {
    using namespace plx::display;
    if (argc < 3) {
        std::fprintf(stderr, "usage: plx_display_experiment DISPLAY.json OUT_PREFIX [threads] "
                             "[container]\n");
        return 2;
    }
    auto display = loadDisplayFile(argv[1]);
    if (!display) {
        std::fprintf(stderr, "error: %s\n", display.status().toString().c_str());
        return 1;
    }
    ExperimentConfig config;
    if (argc > 3) config.threads = std::atoi(argv[3]);
    if (argc > 4) {
        auto kind = parseContainerKind(argv[4]);
        if (!kind) {
            std::fprintf(stderr, "error: %s\n", kind.status().toString().c_str());
            return 1;
        }
        config.container = *kind;
    }
    auto scene = fitSceneToContent(makeShowcaseScene(), *display);
    auto result = runPredistortExperiment(*display, display->defaultViewerMm, scene, config);
    if (!result) {
        std::fprintf(stderr, "error: %s\n", result.status().toString().c_str());
        return 1;
    }
    std::string json = result->dump(2), csv = experimentCsv(*result), prefix = argv[2];
    auto write = [](const std::string& path, const std::string& text) {
        return plx::writeFileBytes(path, {reinterpret_cast<const uint8_t*>(text.data()),
                                          text.size()});
    };
    if (!write(prefix + ".json", json).isOk() || !write(prefix + ".csv", csv).isOk()) {
        std::fprintf(stderr, "error: cannot write %s.*\n", prefix.c_str());
        return 1;
    }
    std::fputs(csv.c_str(), stdout);
    return 0;
}
