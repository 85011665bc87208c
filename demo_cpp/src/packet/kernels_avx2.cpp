// The packet kernels for avx2 (8 lanes; built with -mavx2, no FMA).
#define RT_SIMD_LEVEL 1
#define RT_ISA_NS isa_avx2
#define RT_ISA_GETTER kernels_avx2
#define RT_ISA_NAME "avx2"
#include "packet/kernels.inc"
