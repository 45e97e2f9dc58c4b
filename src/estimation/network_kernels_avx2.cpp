// network_kernels.hpp for AVX2 + FMA (network_kernels_target.inc says how).
#define EMADIAG_NN_VARIANT avx2
#define EMADIAG_NN_ISA "avx2,fma"
#define EMADIAG_NN_AVX512 0
#include "estimation/network_kernels_target.inc"
