#pragma once
// Shared by the import tests: a failed import whose one-line message names the file.

#include <string>

#include <gtest/gtest.h>

#include <plx/scene/import.h>

namespace plx::scene {

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
