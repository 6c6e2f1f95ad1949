// availableMemoryBytes follows the limits a user sets; the resident counts follow what the
// process touches.

#include <cstring>
#include <filesystem>
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

// A fake cgroup hierarchy under the test's output folder: files written from (path, text).
struct FakeCgroups {
    std::filesystem::path root;
    explicit FakeCgroups(const std::string& name)
        : root(std::filesystem::path(PLX_TEST_OUTPUT_DIR) / "core_memory" / name) {
        std::filesystem::remove_all(root);
    }
    void write(const std::string& path, const std::string& text) const {
        const std::filesystem::path file = root / path;
        std::filesystem::create_directories(file.parent_path());
        std::ofstream(file) << text;
    }
    std::optional<uint64_t> remaining() const {
        return cgroupMemoryRemaining((root / "self_cgroup").string(), (root / "sys").string());
    }
};

TEST(Memory, CgroupLimitLessWhatTheKernelCannotReclaim) {
    // v2: limit 1,000,000, usage 600,000 of which 100,000 inactive file cache.
    FakeCgroups v2("v2");
    v2.write("self_cgroup", "0::/user/job\n");
    v2.write("sys/user/job/memory.max", "1000000\n");
    v2.write("sys/user/job/memory.current", "600000\n");
    v2.write("sys/user/job/memory.stat", "anon 400000\nfile 200000\ninactive_file 100000\n");
    EXPECT_EQ(v2.remaining(), 500000u);
    v2.write("sys/user/job/memory.max", "max\n");
    EXPECT_EQ(v2.remaining(), std::nullopt);

    // Hybrid: the unified hierarchy holds no memory controller here, v1's does (listed with
    // another controller), and usage beyond the limit leaves nothing.
    FakeCgroups v1("v1");
    v1.write("self_cgroup", "0::/\n5:cpu,cpuacct:/x\n4:blkio,memory:/x\n");
    v1.write("sys/memory/x/memory.limit_in_bytes", "2000\n");
    v1.write("sys/memory/x/memory.usage_in_bytes", "1500\n");
    v1.write("sys/memory/x/memory.stat", "cache 900\ninactive_file 600\ntotal_inactive_file 700\n");
    EXPECT_EQ(v1.remaining(), 1200u);
    v1.write("sys/memory/x/memory.usage_in_bytes", "9000\n");
    v1.write("sys/memory/x/memory.stat", "");
    EXPECT_EQ(v1.remaining(), 0u);

    FakeCgroups none("none");
    none.write("self_cgroup", "1:cpu:/\n");
    EXPECT_EQ(none.remaining(), std::nullopt);
}

}  // namespace
}  // namespace plx
