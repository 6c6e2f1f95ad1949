#pragma once
// The example displays of examples/displays/*.json, embedded in the binary at build time
// (embed_files.cmake), so that the demo, the benchmarks and `--display NAME` run from any
// directory.

#include <span>
#include <string>
#include <string_view>

#include <plx/core/status.h>
#include <plx/display/optics.h>

namespace plx::cli {

struct ExampleDisplay {
    std::string_view name;  // the file name without ".json" ("cone_showcase")
    std::string_view json;  // the file's bytes
};

// All embedded examples, sorted by name. Defined in the generated example_displays_data.cpp.
std::span<const ExampleDisplay> exampleDisplays();

// The embedded example of that name, or nullptr.
const ExampleDisplay* findExampleDisplay(std::string_view name);

// "cone_showcase, cylinder_mirror, ..." for help texts and errors.
std::string exampleDisplayNames();

// A display argument: the file at that path when one exists, else the embedded example of that
// name, else the file's error (naming the path). Errors: unreadable or invalid descriptions.
Result<display::Display> loadDisplayArgument(const std::string& pathOrName);

// An embedded example by name, parsed. Precondition: the example exists.
display::Display exampleDisplay(std::string_view name);

}  // namespace plx::cli
