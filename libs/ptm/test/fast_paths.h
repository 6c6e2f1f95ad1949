#pragma once
// White-box checks of the PTM kernels' vector passes against their scalar loops, compiled once
// per ISA (fast_paths.inl) so that each ISA's passes are checked with that ISA's code; run by
// fast_paths_test.cpp for every ISA this machine has.

#include <plx/core/cpu.h>

namespace plx::ptm::detail {

// The outcome of one check over many cases: how many were compared, how many differed, and the
// first difference in words. vectorCases counts the cases a vector path took part in.
struct PassReport {
    int cases = 0;
    int vectorCases = 0;
    int failures = 0;
    char first[240] = {};
};

PLX_ISA_DECLARE(PassReport prepareRowReport())
PLX_ISA_DECLARE(PassReport codeRowReport())
PLX_ISA_DECLARE(PassReport runContextsReport())
PLX_ISA_DECLARE(PassReport epsContextsReport())
PLX_ISA_DECLARE(PassReport finishRowReport())
PLX_ISA_DECLARE(PassReport finishRowEdgesReport())
PLX_ISA_DECLARE(PassReport extraBitsReport())
PLX_ISA_DECLARE(PassReport ransRunsReport())
PLX_ISA_DECLARE(PassReport smallAlphabetReport())

}  // namespace plx::ptm::detail
