// Which instruction set the batched path runs on (simulator.hpp: simd_target, set_simd_target).
// Highway picks the widest target the CPU has; a narrower one is forced by disabling every better
// target (hwy::DisableTargets, which the next HWY_DYNAMIC_DISPATCH honours). "scalar" bypasses
// Highway for the step and runs the batch one simulation at a time on the scalar path; the kernels
// that still dispatch (term_sincos_many) get Highway's baseline target.
#include "simd_target.hpp"

#include "batch_kernels.hpp"
#include "emadiag/sim/sim_error.hpp"

#include <hwy/highway.h>

#include <atomic>
#include <cctype>
#include <cstdlib>
#include <mutex>

namespace emadiag::sim {
namespace {

struct NamedTarget {
    const char* name;
    std::int64_t bits;  // Highway target bits
};
// Narrowest first. Highway orders targets the other way: a lower bit is a better target.
// AVX3_DL (AVX-512 with VNNI, VBMI2, ...) only exists in EMADIAG_NATIVE builds on such CPUs.
#if HWY_ARCH_X86
constexpr NamedTarget kTargets[] = {{"sse4", HWY_SSE4}, {"avx2", HWY_AVX2}, {"avx512", HWY_AVX3 | HWY_AVX3_DL}};
#elif HWY_ARCH_ARM
constexpr NamedTarget kTargets[] = {{"neon", HWY_NEON}};
#else
constexpr NamedTarget kTargets[] = {{"emu128", HWY_EMU128}};
#endif

std::string lower(std::string s) {
    for (auto& ch : s) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    return s;
}

/// What the CPU supports among the targets this library was compiled for, before any narrowing.
std::int64_t cpu_targets() {
    static const std::int64_t bits = [] {
        hwy::DisableTargets(0);
        return hwy::SupportedTargets() & HWY_TARGETS;
    }();
    return bits;
}

std::atomic<bool> g_scalar{false};
std::mutex g_mutex;
bool g_initialised = false;  // guarded by g_mutex

std::string supported_list() {
    std::string s;
    for (const auto& name : supported_simd_targets()) s += (s.empty() ? "" : ", ") + name;
    return s;
}

void apply(const std::string& name, const char* source) {
    const std::string v = lower(name);
    if (v == "scalar") {
        // The step runs on the baseline copy (simulate, simulate_batch); what still dispatches through
        // Highway (term_sincos_kernels.cpp) gets its baseline copy too: no target can be disabled below it.
        hwy::DisableTargets(~std::int64_t{0});
        g_scalar = true;
        return;
    }
    if (v == "best" || v.empty()) {
        hwy::DisableTargets(0);
        g_scalar = false;
        return;
    }
    for (const auto& t : kTargets) {
        if (v != t.name) continue;
        if ((cpu_targets() & t.bits) == 0) {
            throw SimError(std::string(source) + " '" + name + "' is not supported by this CPU; supported: " +
                           supported_list());
        }
        const std::int64_t best_bit = t.bits & -t.bits;
        hwy::DisableTargets(best_bit - 1);  // every better target
        g_scalar = false;
        return;
    }
    throw SimError(std::string(source) + " '" + name + "' is not a SIMD target; expected best or one of: " +
                   supported_list());
}

/// First use: the environment variable, if set.
void ensure_initialised() {
    const std::lock_guard<std::mutex> lock(g_mutex);
    if (g_initialised) return;
    (void)cpu_targets();
    g_initialised = true;
    const char* env = std::getenv(kSimdEnvVar);
    if (env != nullptr && *env != '\0') apply(env, kSimdEnvVar);
}

std::string our_name(const char* highway_name) {
    for (const auto& t : kTargets) {
        for (std::int64_t bits = t.bits; bits != 0; bits &= bits - 1) {
            if (hwy::TargetName(bits & -bits) == std::string(highway_name)) return t.name;
        }
    }
    return lower(highway_name);
}

}  // namespace

std::vector<std::string> supported_simd_targets() {
    std::vector<std::string> out{"scalar"};
    for (const auto& t : kTargets) {
        if ((cpu_targets() & t.bits) != 0) out.emplace_back(t.name);
    }
    return out;
}

std::vector<std::string> compiled_simd_targets() {
    std::vector<std::string> out;
    // Highway: a lower bit is a better target, so the highest bit set is the narrowest.
    for (int bit = 62; bit >= 0; --bit) {
        const std::int64_t t = std::int64_t{1} << bit;
        if ((HWY_TARGETS & t) != 0 && t != HWY_SCALAR) out.push_back(our_name(hwy::TargetName(t)));
    }
    out.insert(out.begin(), "scalar");  // simulate's own path, whatever Highway holds
    return out;
}

void set_simd_target(const std::string& name) {
    ensure_initialised();
    const std::lock_guard<std::mutex> lock(g_mutex);
    apply(name, "SIMD target");
}

SimdTarget simd_target() {
    ensure_initialised();
    if (g_scalar) return SimdTarget{"scalar", 1, 1};
    const detail::BatchShape shape = detail::batch_shape();
    return SimdTarget{our_name(shape.target), shape.lanes, shape.groups};
}

bool detail::batch_runs_scalar() {
    ensure_initialised();
    return g_scalar;
}

}  // namespace emadiag::sim
