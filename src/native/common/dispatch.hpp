// Run-time dispatch to wider instruction sets without tying a build to one CPU: GCC's function multiversioning
// (target_clones) on x86-64 compiles a marked function for the baseline and the listed targets and picks the clone
// when the library is loaded.  On other compilers or architectures the macros are empty and the portable baseline
// path is the only one.
#pragma once

#include <cstdlib>

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
// baseline and AVX2 (no FMA: every clone rounds as the baseline)
#define DUALPOSE_CLONES_AVX2 __attribute__((target_clones("default", "avx2")))
// baseline, AVX2 and x86-64-v4 (AVX-512)
#define DUALPOSE_CLONES_V4 __attribute__((target_clones("default", "avx2", "arch=x86-64-v4")))
// Functions written for AVX-512 only (8 x double vectors), called after a run-time check of the CPU
// (cpu_has_avx512f).  The target enables fused multiply-adds, which -ffp-contract=off keeps out of explicit vector
// code; such functions hold no scalar floating-point code that the SLP vectoriser could fuse (see algebra/rows.cpp).
#define DUALPOSE_HAVE_AVX512 1
#define DUALPOSE_TARGET_AVX512 __attribute__((target("avx512f")))
// Functions written for fused multiply-adds on 4 x double vectors, called after a run-time check (cpu_has_fused).
#define DUALPOSE_TARGET_FUSED __attribute__((target("avx2,fma")))
namespace dualpose {
// Whether the CPU supports FMA and AVX2 (libgcc's check), unless the environment variable DUALPOSE_NO_FMA is set
// to a non-empty value at load (the unfused arithmetic of a CPU without them, e.g. to compare results across
// machines).
inline bool cpu_has_fused() {
    const char* off = std::getenv("DUALPOSE_NO_FMA");
    if (off != nullptr && *off != '\0') return false;
    __builtin_cpu_init();
    return __builtin_cpu_supports("fma") && __builtin_cpu_supports("avx2");
}
// Whether the CPU and the operating system support AVX-512F (libgcc's check: CPUID and the saved register state).
inline bool cpu_has_avx512f() {
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx512f");
}
}  // namespace dualpose
#else
#define DUALPOSE_CLONES_AVX2
#define DUALPOSE_CLONES_V4
#define DUALPOSE_HAVE_AVX512 0
#define DUALPOSE_TARGET_FUSED
namespace dualpose {
inline bool cpu_has_fused() { return false; }
}  // namespace dualpose
#endif
