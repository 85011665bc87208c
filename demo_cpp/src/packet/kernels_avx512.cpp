// The packet kernels for avx512 (16 lanes; built with -mavx512f -ffp-contract=off).
#define RT_SIMD_LEVEL 2
#define RT_ISA_NS isa_avx512
#define RT_ISA_GETTER kernels_avx512
#define RT_ISA_NAME "avx512"
#include "packet/kernels.inc"
