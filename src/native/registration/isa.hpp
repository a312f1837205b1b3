// Whether this compiler builds the x86-64-v4 copy of the registration solver (solve_x86_64_v4.cpp): GCC >= 12 on
// x86-64 (#pragma GCC target with "arch=x86-64-v4", __builtin_cpu_supports("x86-64-v4")).  Elsewhere only the
// baseline build exists.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && __GNUC__ >= 12
#define DUALPOSE_HAVE_X86_64_V4 1
#else
#define DUALPOSE_HAVE_X86_64_V4 0
#endif
