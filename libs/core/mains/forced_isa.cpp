#include "forced_isa.h"

#include <cstdio>
#include <string>

#include <plx/core/cpu.h>

namespace plx::mains {

bool refuseUnknownForcedIsa(const char* program) {
    const std::string problem = isaEnvironmentError();
    if (problem.empty()) return false;
    std::fprintf(stderr, "%s: error: %s\n", program, problem.c_str());
    return true;
}

}  // namespace plx::mains
