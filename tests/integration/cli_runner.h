#pragma once
// Runs the parallax binary from integration tests: captured stdout, stderr and exit code, with a
// timeout so that a hang fails the test instead of stalling the suite.

#include <array>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace plx::testing {

namespace fs = std::filesystem;

struct RunResult {
    int exitCode = -1;
    std::string out, err;
};

// A folder for one test file's outputs, under the build tree.
inline fs::path scratchDir(const std::string& name) {
    fs::path dir = fs::path(PLX_TEST_OUTPUT_DIR) / name;
    fs::create_directories(dir);
    return dir;
}

// `shellPrefix` runs before the command in its shell (a `ulimit -v N; ` for the memory tests).
inline RunResult runParallax(const std::string& args, const std::string& shellPrefix = "") {
    // CTest runs tests in parallel processes: stderr goes to a file unique to this run.
    static std::atomic<int> counter{0};
    fs::path errFile = scratchDir("stderr") / ("run-" + std::to_string(getpid()) + "-" +
                                               std::to_string(counter++) + ".txt");
    std::string cmd = shellPrefix + "timeout 120 " + std::string(PARALLAX_EXE) + " " + args +
                      " 2>" + errFile.string();
    RunResult r;
    FILE* pipe = popen(cmd.c_str(), "r");
    if (!pipe) return r;
    std::array<char, 4096> buf;
    size_t n;
    while ((n = fread(buf.data(), 1, buf.size(), pipe)) > 0) r.out.append(buf.data(), n);
    int status = pclose(pipe);
    r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::ifstream e(errFile);
    r.err.assign(std::istreambuf_iterator<char>(e), {});
    e.close();
    fs::remove(errFile);
    return r;
}

inline void writeFile(const fs::path& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary) << bytes;
}

// A path single-quoted for the shell command line of runParallax.
inline std::string q(const fs::path& p) { return "'" + p.string() + "'"; }

// A failed command: the expected non-zero exit (not a crash or timeout), exactly one line on
// stderr naming the problem, nothing on stdout.
inline void expectOneLineError(const RunResult& r, const std::string& mentions, int code = 1) {
    EXPECT_EQ(r.exitCode, code) << r.err;
    ASSERT_FALSE(r.err.empty());
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.err.rfind("parallax: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(mentions), std::string::npos)
        << "expected '" << mentions << "' in: " << r.err;
    EXPECT_TRUE(r.out.empty()) << r.out;
}

// Peak memory (the memory tests) means nothing under AddressSanitizer (its shadow memory and
// quarantine), and no ulimit -v leaves room for its reserved shadow.
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kUnderAddressSanitizer = true;
#else
inline constexpr bool kUnderAddressSanitizer = false;
#endif

// The memory a command estimated before its work (checkImageMemory: memory_estimate_mb of its
// --json) against the peak it reached (peak_memory_mb), at a size where the image dominates:
// below the peak the check would let through work the kernel may end; far above it, it would
// refuse work the machine can do. `most` bounds estimate / peak from above.
inline void expectEstimateHoldsPeak(const std::string& json, const std::string& command,
                                    double most = 1.25) {
    auto doc = nlohmann::json::parse(json);
    const double estimate = doc["memory_estimate_mb"].get<double>();
    const double peak = doc["peak_memory_mb"].get<double>();
    EXPECT_GE(estimate, 0.97 * peak) << command;
    EXPECT_LE(estimate, most * peak) << command;
}

}  // namespace plx::testing
