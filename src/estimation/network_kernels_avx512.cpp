// network_kernels.hpp for AVX-512 (F, DQ, VL, BW, as Highway's AVX3 target; network_kernels_target.inc
// says how).
#define EMADIAG_NN_VARIANT avx512
#define EMADIAG_NN_ISA "avx512f,avx512dq,avx512vl,avx512bw,avx2,fma"
#define EMADIAG_NN_AVX512 1
#include "estimation/network_kernels_target.inc"
