#pragma once
// Eigen's dense module with the one warning it raises scoped to Eigen itself. GCC 12 reports a false
// -Wmaybe-uninitialized inside Eigen's AVX-512 packet code (_mm512_min_pd, _mm512_max_pd and the
// like start from _mm512_undefined_pd(), whose `__m512d __Y = __Y;` it takes for a read of an
// uninitialised value) when the whole build targets AVX-512: EMADIAG_NATIVE=ON on an AVX-512 CPU,
// measured in network.cpp, scg.cpp and scg_test.cpp. The default build (baseline x86-64) does not
// warn; its AVX-512 code, network_kernels_avx512.cpp, scopes the same warning in
// network_kernels_target.inc. The warning points into Eigen's and GCC's headers, so the region is
// the include: the code of the files that include this header is checked as usual.
// Include it first in those translation units (Eigen's include guard makes later includes no-ops).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <Eigen/Dense>
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif
