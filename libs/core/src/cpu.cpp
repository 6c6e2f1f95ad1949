#include <plx/core/cpu.h>

#include <plx/core/check.h>

#include <atomic>
#include <cstdlib>
#include <mutex>

#include <fmt/format.h>

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define PLX_CPU_X86 1
#include <cpuid.h>
#endif

namespace plx {
namespace {

#if PLX_CPU_X86
// The OS saves the register state an ISA needs: XCR0 bits 1-2 (SSE, AVX) for AVX2, and also
// bits 5-7 (opmask, ZMM0-15 upper halves, ZMM16-31) for AVX-512.
uint64_t readXcr0() {
    uint32_t eax = 0, edx = 0;
    __asm__("xgetbv" : "=a"(eax), "=d"(edx) : "c"(0));
    return (uint64_t(edx) << 32) | eax;
}

bool cpuHasAvx2Tier() {
    unsigned a, b, c, d;
    if (!__get_cpuid_count(1, 0, &a, &b, &c, &d)) return false;
    const bool fma = c & (1u << 12), movbe = c & (1u << 22), osxsave = c & (1u << 27),
               avx = c & (1u << 28), f16c = c & (1u << 29);
    if (!(fma && movbe && osxsave && avx && f16c)) return false;
    if ((readXcr0() & 0x6) != 0x6) return false;
    if (!__get_cpuid_count(7, 0, &a, &b, &c, &d)) return false;
    const bool bmi1 = b & (1u << 3), avx2 = b & (1u << 5), bmi2 = b & (1u << 8);
    if (!__get_cpuid_count(0x80000001, 0, &a, &b, &c, &d)) return false;
    const bool lzcnt = c & (1u << 5);
    return bmi1 && avx2 && bmi2 && lzcnt;
}

bool cpuHasAvx512Tier() {
    if (!cpuHasAvx2Tier()) return false;
    if ((readXcr0() & 0xe6) != 0xe6) return false;
    unsigned a, b, c, d;
    if (!__get_cpuid_count(7, 0, &a, &b, &c, &d)) return false;
    const bool f = b & (1u << 16), dq = b & (1u << 17), cd = b & (1u << 28),
               bw = b & (1u << 30), vl = b & (1u << 31), vbmi = c & (1u << 1);
    return f && dq && cd && bw && vl && vbmi;
}
#endif

struct IsaState {
    std::atomic<int> active{-1};
    std::string envError;
    std::once_flag once;
};

IsaState& state() {
    static IsaState s;
    return s;
}

void initFromEnvironment(IsaState& s) {
    Isa isa = bestIsa();
    if (const char* forced = std::getenv("PLX_FORCE_ISA"); forced && *forced) {
        auto parsed = parseIsa(forced);
        if (!parsed) {
            s.envError = "PLX_FORCE_ISA: " + parsed.status().message();
        } else if (static_cast<int>(*parsed) < static_cast<int>(isa)) {
            isa = *parsed;
        }
    }
    s.active.store(static_cast<int>(isa), std::memory_order_release);
}

IsaState& initialisedState() {
    IsaState& s = state();
    std::call_once(s.once, [&] { initFromEnvironment(s); });
    return s;
}

}  // namespace

std::string_view isaName(Isa isa) {
    switch (isa) {
        case Isa::kScalar: return "scalar";
        case Isa::kAvx2: return "avx2";
        case Isa::kAvx512: return "avx512";
    }
    return "unknown";
}

Result<Isa> parseIsa(std::string_view name) {
    for (Isa isa : {Isa::kScalar, Isa::kAvx2, Isa::kAvx512}) {
        if (name == isaName(isa)) return isa;
    }
    return errorStatus(ErrorCode::kInvalidArgument,
                       fmt::format("unknown instruction set '{}' (expected scalar, avx2 or avx512)",
                                   name));
}

bool isaCompiled(Isa isa) {
    if (isa == Isa::kScalar) return true;
#if PLX_CPU_X86 && !defined(PLX_NO_SIMD) && defined(PLX_ISA_KERNELS)
    return true;
#else
    return false;
#endif
}

bool isaSupportedByCpu(Isa isa) {
    switch (isa) {
        case Isa::kScalar: return true;
#if PLX_CPU_X86
        case Isa::kAvx2: {
            static const bool has = cpuHasAvx2Tier();
            return has;
        }
        case Isa::kAvx512: {
            static const bool has = cpuHasAvx512Tier();
            return has;
        }
#else
        default: return false;
#endif
    }
    return false;
}

Isa bestIsa() {
    for (Isa isa : {Isa::kAvx512, Isa::kAvx2}) {
        if (isaCompiled(isa) && isaSupportedByCpu(isa)) return isa;
    }
    return Isa::kScalar;
}

Isa activeIsa() {
    const int cached = state().active.load(std::memory_order_acquire);
    if (cached >= 0) return static_cast<Isa>(cached);
    return static_cast<Isa>(initialisedState().active.load(std::memory_order_acquire));
}

std::string isaEnvironmentError() { return initialisedState().envError; }

Status setActiveIsa(Isa isa) {
    if (!isaCompiled(isa)) {
        return errorStatus(ErrorCode::kUnsupported,
                           fmt::format("this build has no {} kernels", isaName(isa)));
    }
    if (!isaSupportedByCpu(isa)) {
        return errorStatus(ErrorCode::kUnsupported,
                           fmt::format("this CPU cannot run the {} kernels", isaName(isa)));
    }
    initialisedState().active.store(static_cast<int>(isa), std::memory_order_release);
    return Status::ok();
}

// The saved path was active, so this process can run it.
ActiveIsaGuard::~ActiveIsaGuard() {
    PLX_CHECK(setActiveIsa(mSaved).isOk());
}

std::vector<Isa> runnableIsas() {
    std::vector<Isa> out;
    for (Isa isa : {Isa::kScalar, Isa::kAvx2, Isa::kAvx512}) {
        if (isaCompiled(isa) && isaSupportedByCpu(isa)) out.push_back(isa);
    }
    return out;
}

std::string isaSummary() {
    std::string cpu, compiled;
    for (Isa isa : {Isa::kScalar, Isa::kAvx2, Isa::kAvx512}) {
        if (isaSupportedByCpu(isa)) cpu += fmt::format("{}{}", cpu.empty() ? "" : " ", isaName(isa));
        if (isaCompiled(isa)) {
            compiled += fmt::format("{}{}", compiled.empty() ? "" : " ", isaName(isa));
        }
    }
    return fmt::format("kernels: {} (cpu: {}; built: {})", isaName(activeIsa()), cpu, compiled);
}

}  // namespace plx
