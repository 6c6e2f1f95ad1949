#pragma once
// A test fixture base for running a suite once per ISA path this process can run (runnableIsas:
// the build's and the CPU's), so each path's kernels meet the scalar reference.
//
//   class MyPath : public IsaPathTest {};
//   PLX_INSTANTIATE_ISA_PATHS(MyPath);
//   TEST_P(MyPath, Something) { ... }   // runs with GetParam() active

#include <string>

#include <gtest/gtest.h>

#include <plx/core/cpu.h>

namespace plx::test {

class IsaPathTest : public ::testing::TestWithParam<Isa> {
protected:
    void SetUp() override { ASSERT_TRUE(setActiveIsa(GetParam()).isOk()); }

private:
    ActiveIsaGuard mRestore;
};

inline std::string isaPathName(const ::testing::TestParamInfo<Isa>& info) {
    return std::string(isaName(info.param));
}

}  // namespace plx::test

#define PLX_INSTANTIATE_ISA_PATHS(fixture)                                               \
    INSTANTIATE_TEST_SUITE_P(Isa, fixture, ::testing::ValuesIn(::plx::runnableIsas()), \
                             ::plx::test::isaPathName)
