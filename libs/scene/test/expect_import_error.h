#pragma once
// Shared by the import tests: a failed import whose one-line message names the file.

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include <plx/scene/import.h>

namespace plx::scene {

// An empty folder for one test's files: build/test-output/SUITE/NAME.
inline std::filesystem::path freshTestDir(const std::string& suite, const std::string& name) {
    std::filesystem::path dir = std::filesystem::path(PLX_TEST_OUTPUT_DIR) / suite / name;
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

// Writes bytes to path (creating its folder); returns the path as a string.
inline std::string writeTestFile(const std::filesystem::path& path, const std::string& bytes) {
    std::filesystem::create_directories(path.parent_path());
    std::ofstream(path, std::ios::binary) << bytes;
    return path.string();
}

// Expects a failed import whose message names the file and contains `problem`.
inline void expectError(const std::string& path, const std::string& problem,
                        const ImportOptions& options = {}) {
    auto s = importFile(path, options);
    ASSERT_FALSE(s.isOk()) << path;
    const std::string& msg = s.status().message();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find(problem), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
}

}  // namespace plx::scene
