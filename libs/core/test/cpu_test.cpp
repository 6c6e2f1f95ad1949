#include <plx/core/cpu.h>

#include <gtest/gtest.h>

#include <cstdint>
#include <numeric>
#include <vector>

namespace plx::test {
PLX_ISA_DECLARE(int compiledIsaLevel())
PLX_ISA_DECLARE(int generatedIsaLevel())
PLX_ISA_DECLARE(uint64_t sumOfSquares(const uint32_t* values, int count))
}  // namespace plx::test

namespace plx::test {
namespace {

TEST(Cpu, IsaNamesRoundTrip) {
    for (Isa isa : {Isa::kScalar, Isa::kAvx2, Isa::kAvx512}) {
        auto parsed = parseIsa(isaName(isa));
        ASSERT_TRUE(parsed.isOk());
        EXPECT_EQ(*parsed, isa);
    }
    auto bad = parseIsa("sse9");
    ASSERT_FALSE(bad.isOk());
    EXPECT_NE(bad.status().message().find("sse9"), std::string::npos);
}

TEST(Cpu, ScalarIsAlwaysRunnableAndTiersNest) {
    auto runnable = runnableIsas();
    ASSERT_FALSE(runnable.empty());
    EXPECT_EQ(runnable.front(), Isa::kScalar);
    if (isaSupportedByCpu(Isa::kAvx512)) {
        EXPECT_TRUE(isaSupportedByCpu(Isa::kAvx2));
    }
    EXPECT_EQ(runnable.back(), bestIsa());
}

TEST(Cpu, ActivePathIsCappedByTheEnvironment) {
    const char* forced = std::getenv("PLX_FORCE_ISA");
    if (!forced) {
        EXPECT_EQ(activeIsa(), bestIsa());
        return;
    }
    auto parsed = parseIsa(forced);
    ASSERT_TRUE(parsed.isOk()) << isaEnvironmentError();
    EXPECT_LE(static_cast<int>(activeIsa()), static_cast<int>(*parsed));
}

TEST(Cpu, GuardPutsBackThePathActiveWhenItWasMade) {
    const Isa before = activeIsa();
    for (Isa isa : runnableIsas()) {
        {
            ActiveIsaGuard restore;
            ASSERT_TRUE(setActiveIsa(isa).isOk());
            EXPECT_EQ(activeIsa(), isa);
        }
        EXPECT_EQ(activeIsa(), before) << isaName(isa);
    }
}

TEST(Cpu, DispatchReachesTheKernelBuiltForEachPath) {
    ActiveIsaGuard restore;
    for (Isa isa : runnableIsas()) {
        ASSERT_TRUE(setActiveIsa(isa).isOk());
        EXPECT_EQ(PLX_ISA_PICK(generatedIsaLevel)(), static_cast<int>(isa)) << isaName(isa);
#if !defined(PLX_NATIVE_BUILD)
        EXPECT_EQ(PLX_ISA_PICK(compiledIsaLevel)(), static_cast<int>(isa)) << isaName(isa);
#endif
    }
}

TEST(Cpu, EveryPathComputesTheScalarResult) {
    ActiveIsaGuard restore;
    std::vector<uint32_t> values(1037);
    std::iota(values.begin(), values.end(), 4000000000u - 1037u);
    const uint64_t reference =
        isa_scalar::sumOfSquares(values.data(), static_cast<int>(values.size()));
    for (Isa isa : runnableIsas()) {
        ASSERT_TRUE(setActiveIsa(isa).isOk());
        EXPECT_EQ(PLX_ISA_PICK(sumOfSquares)(values.data(), static_cast<int>(values.size())),
                  reference)
            << isaName(isa);
    }
}

TEST(Cpu, UnavailablePathsAreRefused) {
    ActiveIsaGuard restore;
    for (Isa isa : {Isa::kAvx2, Isa::kAvx512}) {
        if (isaCompiled(isa) && isaSupportedByCpu(isa)) continue;
        Status status = setActiveIsa(isa);
        EXPECT_FALSE(status.isOk());
        EXPECT_NE(status.message().find(isaName(isa)), std::string::npos);
    }
}

TEST(Cpu, SummaryNamesTheActivePath) {
    EXPECT_NE(isaSummary().find(isaName(activeIsa())), std::string::npos);
}

}  // namespace
}  // namespace plx::test
