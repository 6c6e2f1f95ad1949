// availableMemoryBytes follows the limits a user sets; the resident counts follow what the
// process touches.

#include <cstring>
#include <fstream>
#include <memory>
#include <string>

#include <sys/resource.h>

#include <gtest/gtest.h>

#include <plx/core/memory.h>

namespace plx {
namespace {

constexpr uint64_t kMiB = uint64_t(1) << 20;

TEST(Memory, ResidentCountsFollowTouchedPages) {
    const uint64_t before = residentBytes();
    ASSERT_GT(before, 0u);
    const size_t bytes = 64 * kMiB;
    std::unique_ptr<char[]> block(new char[bytes]);
    std::memset(block.get(), 1, bytes);
    EXPECT_GE(residentBytes(), before + bytes - 4 * kMiB);
    EXPECT_GE(peakResidentBytes(), residentBytes() - kMiB);
    EXPECT_EQ(block[bytes - 1], 1);
}

// VmData of /proc/self/status in bytes: what RLIMIT_DATA is held against.
uint64_t dataBytes() {
    std::ifstream in("/proc/self/status");
    for (std::string line; std::getline(in, line);)
        if (line.rfind("VmData:", 0) == 0) return std::stoull(line.substr(7)) * 1024;
    return 0;
}

TEST(Memory, AvailableHonoursTheDataLimit) {
    const std::optional<uint64_t> unlimited = availableMemoryBytes();
    if (!unlimited) GTEST_SKIP() << "no /proc/meminfo on this system";
    rlimit saved{};
    ASSERT_EQ(getrlimit(RLIMIT_DATA, &saved), 0);
    const uint64_t headroom = 256 * kMiB;
    const uint64_t used = dataBytes();
    ASSERT_GT(used, 0u);
    if (saved.rlim_cur != RLIM_INFINITY && saved.rlim_cur < used + headroom)
        GTEST_SKIP() << "the data limit is already below " << used + headroom << " bytes";
    rlimit lowered = saved;
    lowered.rlim_cur = used + headroom;
    ASSERT_EQ(setrlimit(RLIMIT_DATA, &lowered), 0);
    const std::optional<uint64_t> limited = availableMemoryBytes();
    ASSERT_EQ(setrlimit(RLIMIT_DATA, &saved), 0);
    ASSERT_TRUE(limited.has_value());
    // What the process mapped between the two readings of VmData is all the slack there is.
    EXPECT_LE(*limited, headroom);
    EXPECT_GE(*limited, headroom / 2);
    if (*unlimited > headroom) {
        EXPECT_LT(*limited, *unlimited);
    }
}

}  // namespace
}  // namespace plx
