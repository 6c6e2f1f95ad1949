#include "example_displays.h"

#include <filesystem>

#include <plx/display/display_json.h>

namespace plx::cli {

const ExampleDisplay* findExampleDisplay(std::string_view name) {
    for (const ExampleDisplay& e : exampleDisplays())
        if (e.name == name) return &e;
    return nullptr;
}

std::string exampleDisplayNames() {
    std::string names;
    for (const ExampleDisplay& e : exampleDisplays()) {
        if (!names.empty()) names += ", ";
        names += e.name;
    }
    return names;
}

Result<display::Display> loadDisplayArgument(const std::string& pathOrName) {
    std::error_code ec;
    if (!std::filesystem::exists(pathOrName, ec))
        if (const ExampleDisplay* e = findExampleDisplay(pathOrName))
            return display::parseDisplayJson(e->json);
    return display::loadDisplayFile(pathOrName);
}

display::Display exampleDisplay(std::string_view name) {
    const ExampleDisplay* e = findExampleDisplay(name);
    PLX_CHECK(e != nullptr);
    auto d = display::parseDisplayJson(e->json);
    PLX_CHECK(d.isOk());
    return *d;
}

}  // namespace plx::cli
