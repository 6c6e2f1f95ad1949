#pragma once
// Private: the namespace of the PTM kernel headers (lanes.h and the headers built on it). In a
// per-ISA translation unit (plx_add_isa_kernels) it is that ISA's (isa_scalar, isa_avx2,
// isa_avx512); elsewhere isa_baseline. Every inline function and template of those headers then
// has one name per ISA, so the linker never keeps an AVX-512 copy for a baseline caller.
// They open it as an inline namespace of plx::ptm::detail, so callers name them detail::X.

#if defined(PLX_ISA_NS)
#define PLX_PTM_KERNEL_NS PLX_ISA_NS
#else
#define PLX_PTM_KERNEL_NS isa_baseline
#endif
