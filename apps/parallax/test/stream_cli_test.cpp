// parallax stream build and merge run as a user would: the JSON fields, the same bytes on every
// run and thread count, range builds merged equal to the whole build, one-line errors.

#include <map>

#include <nlohmann/json.hpp>

#include "cli_runner.h"

namespace {

using namespace plx::testing;

// Every file below dir, by relative path.
std::map<std::string, std::string> filesBelow(const fs::path& dir) {
    std::map<std::string, std::string> files;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.is_regular_file()) {
            std::ifstream in(e.path(), std::ios::binary);
            files[fs::relative(e.path(), dir).string()] =
                std::string(std::istreambuf_iterator<char>(in), {});
        }
    return files;
}

// A quick sampling: museum:4 has 4 rooms and 14 textures.
const std::string kSampling = " --samples 2 --face-size 32";

RunResult build(const fs::path& out, const std::string& extra) {
    fs::remove_all(out);
    return runParallax("stream build museum:4 --out " + out.string() + kSampling + extra);
}

TEST(StreamCli, JsonFieldsAndTheSameBytesOnEveryThreadCount) {
    fs::path dir = scratchDir("stream_cli");
    RunResult one = build(dir / "t1", " --threads 1 --json");
    ASSERT_EQ(one.exitCode, 0) << one.err;
    EXPECT_TRUE(one.err.empty()) << one.err;  // no progress bar with --json
    auto doc = nlohmann::json::parse(one.out);
    for (const char* key : {"cells", "cells_per_s", "textures", "bytes", "pvs_mean", "pvs_max"})
        EXPECT_TRUE(doc.contains(key)) << key;
    EXPECT_EQ(doc["cells"], 4);
    EXPECT_EQ(doc["cells_from"], "rooms");
    RunResult two = build(dir / "t2", " --threads 2 --json");
    ASSERT_EQ(two.exitCode, 0) << two.err;
    auto a = filesBelow(dir / "t1"), b = filesBelow(dir / "t2");
    EXPECT_EQ(a.size(), 1u + 2 * 4 + doc["textures"].get<size_t>());
    uint64_t bytes = 0;
    for (const auto& [name, data] : a) bytes += data.size();
    EXPECT_EQ(doc["bytes"].get<uint64_t>(), bytes);
    EXPECT_TRUE(a == b);
}

TEST(StreamCli, RangeBuildsMergedEqualTheWholeBuild) {
    fs::path dir = scratchDir("stream_cli");
    ASSERT_EQ(build(dir / "whole", "").exitCode, 0);
    fs::remove_all(dir / "parts");
    for (const char* range : {"0-0", "1-3"}) {
        RunResult r = runParallax("stream build museum:4 --out " + (dir / "parts").string() +
                                  kSampling + " --cells " + range);
        ASSERT_EQ(r.exitCode, 0) << r.err;
    }
    fs::remove_all(dir / "merged");
    const std::string parts =
        (dir / "parts/part-0-0.json").string() + " " + (dir / "parts/part-1-3.json").string();
    RunResult m = runParallax("stream merge museum:4 --out " + (dir / "merged").string() + " " +
                              parts + " --json");
    ASSERT_EQ(m.exitCode, 0) << m.err;
    EXPECT_TRUE(filesBelow(dir / "whole") == filesBelow(dir / "merged"));
    // A missing range, or parts of another scene, are one-line errors.
    RunResult gap = runParallax("stream merge museum:4 --out " + (dir / "gap").string() + " " +
                                (dir / "parts/part-1-3.json").string());
    expectOneLineError(gap, "no part holds cell 0");
    RunResult other =
        runParallax("stream merge museum:5 --out " + (dir / "gap").string() + " " + parts);
    expectOneLineError(other, "another scene");
}

TEST(StreamCli, BadArgumentsAreOneLineErrors) {
    fs::path dir = scratchDir("stream_cli");
    const std::string out = " --out " + (dir / "bad").string();
    expectOneLineError(runParallax("stream build museum:4" + out + " --samples 0"), "--samples", 2);
    expectOneLineError(runParallax("stream build museum:4" + out + " --face-size 3"), "--face-size",
                       2);
    expectOneLineError(runParallax("stream build museum:4" + out + " --cells 3-1"), "--cells", 2);
    expectOneLineError(runParallax("stream build museum:4" + out + " --cells 0-4"), "cells 0-3", 2);
    expectOneLineError(runParallax("stream build museum:4" + out + " --cells x"), "--cells", 2);
    writeFile(dir / "plain", "x");
    expectOneLineError(runParallax("stream build museum:4 --out " + (dir / "plain").string()),
                       "not a folder", 2);
    writeFile(dir / "part.json", "{\"format\":\"parallax-stream-part\",\"version\":1");
    expectOneLineError(
        runParallax("stream merge museum:4" + out + " " + (dir / "part.json").string()),
        "part file");
}

}  // namespace
