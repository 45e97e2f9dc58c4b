// network_kernels.hpp on the build's baseline instruction set (SSE2 on baseline x86-64).
#define EMADIAG_NN_VARIANT baseline
#include "estimation/network_kernels-inl.h"
