#pragma once
// Which instruction-set path the hot kernels take, chosen once per process from CPUID.
//
// A default build runs on any x86-64 CPU. Each hot kernel is written once over a lane vocabulary
// in an `.inl`, compiled once per ISA below with that ISA's flags (cmake/PlxTargets.cmake,
// plx_add_isa_kernels) and picked at run time through `activeIsa()`. The scalar path is the
// reference every other path is tested against.
//
// The tiers (each implies the one before it):
//   scalar  baseline x86-64 (SSE2), or any other processor; the only path of a PLX_NO_SIMD build
//   avx2    x86-64-v3: AVX2, FMA, BMI1/2, F16C, LZCNT, MOVBE (Haswell, Zen 1 and later)
//   avx512  x86-64-v4 (AVX-512 F, BW, CD, DQ, VL) plus VBMI (Ice Lake, Zen 4 and later; a CPU
//           with AVX-512 but without VBMI, such as Skylake-SP, takes the avx2 path)
//
// The environment variable PLX_FORCE_ISA=scalar|avx2|avx512 caps the path, so tests and
// benchmarks can run every path the machine has. A cap above what the CPU supports is lowered
// to the best supported path (never an illegal instruction).

#include <plx/core/status.h>

#include <string>
#include <string_view>
#include <vector>

namespace plx {

enum class Isa : int { kScalar = 0, kAvx2 = 1, kAvx512 = 2 };

// "scalar", "avx2" or "avx512".
std::string_view isaName(Isa isa);

// Parses a name accepted by PLX_FORCE_ISA; an unknown name is an error naming it.
Result<Isa> parseIsa(std::string_view name);

// Whether this build compiled the kernels for `isa` (PLX_NO_SIMD and non-x86 builds: scalar only).
bool isaCompiled(Isa isa);

// Whether this CPU (and its operating system, for the AVX state) can run `isa`.
bool isaSupportedByCpu(Isa isa);

// The best path that is both compiled and supported by the CPU.
Isa bestIsa();

// The path the kernels take: bestIsa() capped by PLX_FORCE_ISA, read once on first use. A bad
// PLX_FORCE_ISA value is reported by isaEnvironmentError() and otherwise ignored.
Isa activeIsa();

// The problem with PLX_FORCE_ISA, if any ("" when it is unset or valid).
std::string isaEnvironmentError();

// Makes `isa` the active path for the rest of the process (tests and benchmarks that compare
// paths in one process). Fails, changing nothing, when the build or the CPU lacks it.
Status setActiveIsa(Isa isa);

// Every path this process can run, scalar first.
std::vector<Isa> runnableIsas();

// Puts back, when it goes out of scope, the path that was active when it was made: for tests and
// benchmarks that switch paths with setActiveIsa, so that an early return (a failed assertion)
// does not leave the rest of the process on another path.
class ActiveIsaGuard {
public:
    ActiveIsaGuard() = default;
    ~ActiveIsaGuard();
    ActiveIsaGuard(const ActiveIsaGuard&) = delete;
    ActiveIsaGuard& operator=(const ActiveIsaGuard&) = delete;

private:
    Isa mSaved = activeIsa();
};

// One line for --version: the active path, what the CPU supports and what was compiled.
std::string isaSummary();

// The entry for the active path out of a module's three per-ISA definitions of one kernel.
template <class Fn>
Fn pickIsa(Fn scalar, Fn avx2, Fn avx512) {
    switch (activeIsa()) {
        case Isa::kAvx512: return avx512;
        case Isa::kAvx2: return avx2;
        case Isa::kScalar: break;
    }
    return scalar;
}

// The same for a kernel built for scalar and avx2 only (plx_add_isa_kernels ... ISAS avx2):
// CPUs with AVX-512 take its avx2 entry.
template <class Fn>
Fn pickIsa(Fn scalar, Fn avx2) {
    return activeIsa() == Isa::kScalar ? scalar : avx2;
}

}  // namespace plx

// For a module's dispatch code, inside the module's namespace:
//   PLX_ISA_DECLARE(void rasterTile(const Tile& tile));   // declares isa_scalar::rasterTile, ...
//   PLX_ISA_PICK(rasterTile)(tile);                       // calls the active path's definition
// PLX_ISA_KERNELS is defined when the build compiles the avx2 and avx512 kernels.
#define PLX_ISA_DECLARE(...)                 \
    namespace isa_scalar { __VA_ARGS__; }    \
    namespace isa_avx2 { __VA_ARGS__; }      \
    namespace isa_avx512 { __VA_ARGS__; }
// PLX_ISA_PICK_UP_TO_AVX2 is PLX_ISA_PICK for a kernel built with ISAS avx2.
#if defined(PLX_ISA_KERNELS)
#define PLX_ISA_PICK(fn) ::plx::pickIsa(&isa_scalar::fn, &isa_avx2::fn, &isa_avx512::fn)
#define PLX_ISA_PICK_UP_TO_AVX2(fn) ::plx::pickIsa(&isa_scalar::fn, &isa_avx2::fn)
#else
#define PLX_ISA_PICK(fn) (&isa_scalar::fn)
#define PLX_ISA_PICK_UP_TO_AVX2(fn) (&isa_scalar::fn)
#endif
