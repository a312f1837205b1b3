// Run-time dispatch to wider instruction sets without tying a build to one CPU: GCC's function multiversioning
// (target_clones) on x86-64 compiles a marked function for the baseline and the listed targets and picks the clone
// when the library is loaded.  On other compilers or architectures the macros are empty and the portable baseline
// path is the only one.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
// baseline and AVX2 (no FMA: every clone rounds as the baseline)
#define DUALPOSE_CLONES_AVX2 __attribute__((target_clones("default", "avx2")))
// baseline, AVX2 and x86-64-v4 (AVX-512)
#define DUALPOSE_CLONES_V4 __attribute__((target_clones("default", "avx2", "arch=x86-64-v4")))
#else
#define DUALPOSE_CLONES_AVX2
#define DUALPOSE_CLONES_V4
#endif
