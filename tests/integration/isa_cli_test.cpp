// The portable binary as a user runs it: every kernel path this CPU has (PLX_FORCE_ISA) writes
// the same bytes as the scalar reference path, --version names the path, and a bad
// PLX_FORCE_ISA value is a one-line usage error.

#include <cstdlib>
#include <map>

#include <plx/core/cpu.h>
#include <plx/core/image_io.h>

#include "cli_runner.h"

namespace {

using namespace plx::testing;

// Sets PLX_FORCE_ISA for the parallax processes this test starts, restoring it afterwards.
class ForcedIsa {
public:
    explicit ForcedIsa(const std::string& value) {
        if (const char* old = std::getenv("PLX_FORCE_ISA")) mOld = old;
        setenv("PLX_FORCE_ISA", value.c_str(), 1);
    }
    ~ForcedIsa() {
        if (mOld.empty()) unsetenv("PLX_FORCE_ISA");
        else setenv("PLX_FORCE_ISA", mOld.c_str(), 1);
    }

private:
    std::string mOld;
};

using FileBytes = std::vector<uint8_t>;

// Runs the same commands with one path forced and returns every file they wrote, by name.
std::map<std::string, FileBytes> outputsOfPath(plx::Isa isa) {
    const std::string name(plx::isaName(isa));
    fs::path dir = scratchDir("isa") / name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    ForcedIsa forced(name);
    const std::string d = dir.string();
    const std::vector<std::string> commands = {
        "render office:3 --size 200x120 --threads 2 --out " + d + "/office",
        "render museum:1 --size 160x96 --shading textured --threads 2 --out " + d + "/museum",
        "stereo office:2 --size 160x96 --method pbuffer --conservative --threads 2 --out " + d +
            "/pbuffer",
        "ptm encode " + d + "/museum.color.png -o " + d + "/museum.ptm",
        "ptm decode " + d + "/museum.ptm -o " + d + "/museum.decoded.png",
    };
    for (const std::string& command : commands) {
        RunResult r = runParallax(command);
        EXPECT_EQ(r.exitCode, 0) << name << ": " << command << "\n" << r.err;
    }
    std::map<std::string, FileBytes> files;
    for (const auto& entry : fs::directory_iterator(dir)) {
        auto bytes = plx::readFileBytes(entry.path().string());
        EXPECT_TRUE(bytes.isOk()) << bytes.status().toString();
        if (bytes) files[entry.path().filename().string()] = std::move(*bytes);
    }
    return files;
}

TEST(IsaCli, EveryPathWritesTheScalarPathsBytes) {
    const auto reference = outputsOfPath(plx::Isa::kScalar);
    ASSERT_GE(reference.size(), 8u);
    for (plx::Isa isa : plx::runnableIsas()) {
        if (isa == plx::Isa::kScalar) continue;
        const auto files = outputsOfPath(isa);
        ASSERT_EQ(files.size(), reference.size()) << plx::isaName(isa);
        for (const auto& [name, bytes] : reference) {
            auto it = files.find(name);
            ASSERT_NE(it, files.end()) << plx::isaName(isa) << " wrote no " << name;
            EXPECT_TRUE(it->second == bytes) << plx::isaName(isa) << ": " << name << " differs";
        }
    }
}

TEST(IsaCli, VersionNamesTheForcedPath) {
    for (plx::Isa isa : plx::runnableIsas()) {
        ForcedIsa forced(std::string(plx::isaName(isa)));
        RunResult r = runParallax("--version");
        ASSERT_EQ(r.exitCode, 0) << r.err;
        EXPECT_NE(r.out.find("kernels: " + std::string(plx::isaName(isa)) + " "),
                  std::string::npos)
            << r.out;
    }
}

TEST(IsaCli, BadForcedPathIsAUsageError) {
    ForcedIsa forced("avx1024");
    expectOneLineError(runParallax("info office:1"), "avx1024", 2);
}

}  // namespace
