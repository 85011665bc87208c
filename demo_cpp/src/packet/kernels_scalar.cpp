// The packet kernels for scalar (one lane: CPUs without AVX2).
#define RT_SIMD_LEVEL 0
#define RT_ISA_NS isa_scalar
#define RT_ISA_GETTER kernels_scalar
#define RT_ISA_NAME "scalar"
#include "packet/kernels.inc"
