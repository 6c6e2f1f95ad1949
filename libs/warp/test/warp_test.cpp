#include <gtest/gtest.h>

#include <plx/warp/warp.h>

namespace {

using namespace plx;

TEST(Warp, ParsesNames) {
    EXPECT_EQ(*warp::parseSplat("mesh"), warp::Splat::kMesh);
    EXPECT_FALSE(warp::parseSplat("blob").isOk());
}

}  // namespace
