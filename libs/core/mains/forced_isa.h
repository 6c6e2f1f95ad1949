#pragma once
// For the test and benchmark programs and the experiment drivers: PLX_FORCE_ISA checked as
// parallax checks it (apps/parallax/main.cpp). Without that a misspelt name ("sse2") would leave
// the best kernels running in a run meant to test or time another path.

namespace plx::mains {

// When PLX_FORCE_ISA names no known instruction set, prints "PROGRAM: error: ..." on one line
// and returns true; the caller exits with status 2.
bool refuseUnknownForcedIsa(const char* program);

}  // namespace plx::mains
