#pragma once
// Programmer-error checks (tier 1 of ARCHITECTURE.md). PLX_CHECK is always on; PLX_DCHECK only
// in debug builds. Both print the condition and location and abort: they are for broken
// invariants in our own code, never for untrusted input (use Status for that).

namespace plx::detail {
[[noreturn]] void checkFailed(const char* condition, const char* file, int line);
}

#define PLX_CHECK(cond)                                                   \
    do {                                                                  \
        if (!(cond)) [[unlikely]]                                         \
            ::plx::detail::checkFailed(#cond, __FILE__, __LINE__);        \
    } while (0)

#ifdef NDEBUG
#define PLX_DCHECK(cond) \
    do {                 \
    } while (0)
#else
#define PLX_DCHECK(cond) PLX_CHECK(cond)
#endif
