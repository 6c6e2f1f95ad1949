// The main of the GoogleTest programs (plx_add_test): gtest_main's, after refusing an unknown
// PLX_FORCE_ISA (forced_isa.h), so that a run meant to test one path never tests another.

#include <gtest/gtest.h>

#include "forced_isa.h"

int main(int argc, char** argv) {
    if (plx::mains::refuseUnknownForcedIsa(argv[0])) return 2;
    testing::InitGoogleTest(&argc, argv);
    return RUN_ALL_TESTS();
}
