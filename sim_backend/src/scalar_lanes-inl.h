// The scalar path's lane types (W = 1: one double, one bool) and their operations, for
// step_kernel-inl.h. No include guard: included inside each namespace that compiles the step at
// W = 1, after that namespace's `template <int W> struct Vec` (step_kernel.hpp for the baseline
// copy, batch_kernels.cpp once per Highway target).
template <>
struct Vec<1> {
    using D = double;
    using M = bool;
};
inline double sel(bool m, double a, double b) { return m ? a : b; }
inline double zero_if(bool m, double a) { return m ? 0.0 : a; }
inline double keep_if(bool m, double a) { return m ? a : 0.0; }
inline double vxor(double a, double b) {  // bitwise, as the vector step's Xor
    return std::bit_cast<double>(std::bit_cast<std::uint64_t>(a) ^ std::bit_cast<std::uint64_t>(b));
}
template <class D>
inline D bcast(double a) {
    return 0.0 + a;
}
inline bool vnot(bool m) { return !m; }
inline bool any(bool m) { return m; }
inline double vabs(double a) { return std::fabs(a); }
inline void to_array(double v, double* out) { out[0] = v; }
inline double clamp_below(double a, double lo) { return a < lo ? lo : a; }
inline double vmax(double lo, double a) { return a < lo ? lo : a; }  // clamp_below(a, lo), lo per lane
inline double clamp_above(double a, double hi) { return a > hi ? hi : a; }
