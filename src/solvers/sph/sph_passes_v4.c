/* sph_passes_v4.c — the SPH passes (sph_passes.c) compiled for x86-64-v4, i.e. with the AVX-512
 * neighbour loops, in a portable build (SQ_NATIVE=OFF, GCC on x86-64: CMake sets SQ_SPH_DISPATCH
 * and -march=x86-64-v4 for this file only). The portable passes call these when the CPU has
 * AVX-512 (sq__sph_uses_avx512); elsewhere this file is empty. */
#if defined(SQ_SPH_DISPATCH) && SQ_SPH_DISPATCH
#define SQ__SPH_VARIANT_V4 1
#include "sph_passes.c"
#else
typedef int sq__sph_passes_v4_unused; /* ISO C: a translation unit is not empty */
#endif
