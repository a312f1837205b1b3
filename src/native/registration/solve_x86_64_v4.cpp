// The registration solver (solve.cpp, eigen4.cpp, svd3.cpp) compiled a second time for x86-64-v4 (AVX-512), chosen
// at run time by solve_batch when the CPU has it; the baseline build runs everywhere else.
//
// Why a whole second build rather than target_clones: the solver is a few hundred lines of scalar code that GCC
// packs into short vectors (SLP); with the baseline ISA it runs ~15% slower than with AVX-512 encodings, and
// target_clones on the block loop was no faster than the baseline (measured; see docs/registration.md "Speed").
// Compiled here with 128-bit preferred vectors (the x86-64-v4 default of wider vectors was slower, as was plain
// x86-64-v4 tuning), bit-identical to the baseline build (no FMA contraction: -ffp-contract=off).
//
// How: the shared scalar headers are included first, in namespace dualpose with the baseline target (they are inlined
// into the callers below); then every name of the solver's own files is moved to namespace dualpose_x86_64_v4 by a
// macro, so no symbol of this build can be merged by the linker with a baseline one (an AVX-512 copy of an inline
// function chosen for the baseline path would crash older CPUs).  The solver's files use no std templates for the same
// reason.
#include "isa.hpp"

#if DUALPOSE_HAVE_X86_64_V4
#include "../common/kutil.hpp"
#include "../common/quat.hpp"

#include <cmath>
#include <cstdint>

namespace dualpose_common = dualpose;

#pragma GCC push_options
#pragma GCC target("arch=x86-64-v4,prefer-vector-width=128")
#define DUALPOSE_ISA_VARIANT 1
#define dualpose dualpose_x86_64_v4
namespace dualpose {
using namespace dualpose_common;
}
#include "eigen4.cpp"
#include "solve.cpp"
#include "svd3.cpp"
#undef dualpose
#undef DUALPOSE_ISA_VARIANT
#pragma GCC pop_options
#endif
