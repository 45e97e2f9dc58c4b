// Open-world discovery on seeded runs (docs/discovery.md "Figures"; issue 10): one row per run with
// the injected effect and its magnitude, what discovery named (or the unexplained structure and the
// variable it depends on most), the current error and the trajectory cost before/after, FDJ
// before/after (truth 0.08 N m, the datasheet), and the time of one discover().
// Sets (tests/support/discovery_cases.hpp): the 7 library effects, the development cases, the
// held-out cases (never used to tune), and clean runs (false claims).
// Set dynbrk (not in the default list): pairs of a DYN and a BRK run of one actuator with the same
// injected term, discovered together (docs/discovery.md "Across DYN and BRK"): what the BRK run's
// breakaway asymmetry and the DYN trajectory name together; the clean pairs count false claims.
// Set loads (not in the default list): a flight run and a ground or load-rig run of one actuator with
// the same effect (docs/discovery.md "Across load cases"); the clean pairs count false claims.
// Usage: discovery_bench [runs_per_case=1] [seed=11] [noise=typical|none] [sets=library,dev,heldout,clean]
//                        [clean_runs=10] [plot_dir=]
// With plot_dir, the SVG of every unexplained structure is written there (CASE_SEED.svg).
#include "../tests/support/discovery_cases.hpp"
#include "core/sim_run.hpp"
#include "emadiag/sim/physics.hpp"
#include "discovery/screening/candidate_effect.hpp"
#include "discovery/discovery.hpp"
#include "discovery/many_run/multi_run.hpp"
#include "discovery/residual_plot.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace {

using emadiag::discovery::DiscoveryReport;
namespace tc = emadiag::testcases;

constexpr double kTrueFdjNm = emadiag::sim::ema_ref_1::kFdjNm;  // the datasheet
/// Issue 10's goal for the time of discover() on one run.
constexpr double kGoalCpuS = 2.0;
/// Issue 10's goal where a term is added: the re-simulated current error falls to this share of before
/// or to within 10 % of the noise floor (this factor on it).
constexpr double kCurrentGoalRatio = 0.7;
constexpr double kCurrentGoalFloor = 1.1;

struct Case {
    std::string set, id, expected, variables;  ///< expected name key; acceptable variables of unexplained structure
    emadiag::sim::SimConfig config;
    std::string injected;                       ///< text of the injected effect with its magnitude
    std::vector<std::pair<std::string, double>> truth;  ///< library effects: sim::Effects name and true value
};

/// A fitted coefficient is within its uncertainty when the truth lies in its 95 % interval.
constexpr double kWithinSe = 1.96;

/// Library effects (the simulator's sim::Effects), drawn as in the previous bench.
Case library_case(const std::string& kind, std::mt19937_64& g) {
    Case c;
    c.set = "library";
    c.id = kind;
    c.expected = kind;
    c.config.load_case = emadiag::sim::LoadCase::B;
    c.config.sequence = emadiag::sim::Sequence::Dyn;
    const double sign = tc::uniform(g, 0, 1) < 0.5 ? -1.0 : 1.0;
    std::vector<std::pair<std::string, double>> fx;
    if (kind == "viscous") fx = {{"viscous", tc::uniform(g, 2e-5, 1e-4)}};
    if (kind == "stribeck") fx = {{"stribeck_amplitude", tc::uniform(g, 0.03, 0.1)}, {"stribeck_speed", tc::uniform(g, 30, 100)}};
    if (kind == "spall")
        fx = {{"spall_amplitude", tc::uniform(g, 0.03, 0.1)}, {"spall_center", tc::uniform(g, -10, 2)}, {"spall_width", tc::uniform(g, 0.5, 2.0)}};
    if (kind == "ripple") fx = {{"ripple_amplitude", tc::uniform(g, 0.03, 0.1)}, {"ripple_periods", 6.0}};
    if (kind == "current_gain_error") fx = {{"current_gain_error", sign * tc::uniform(g, 0.02, 0.06)}};
    if (kind == "hinge_offset") fx = {{"hinge_offset", sign * tc::uniform(g, 40, 150)}};
    if (kind == "inertia") fx = {{"true_inertia", emadiag::sim::EmaParams{}.j_kgm2 * tc::uniform(g, 1.1, 1.3)}};
    c.truth = fx;
    for (const auto& [k, v] : fx) {
        c.config.params.effects.set(k, v);
        char b[64];
        std::snprintf(b, sizeof b, "%s%s=%.4g", c.injected.empty() ? "" : " ", k.c_str(), v);
        c.injected += b;
    }
    return c;
}

std::string join(const std::vector<std::string>& v, const char* sep = "+") {
    std::string s;
    for (const auto& x : v) s += (s.empty() ? "" : sep) + x;
    return s;
}

bool listed(const std::string& list, const std::string& item) {
    std::stringstream ss(list);
    std::string x;
    while (std::getline(ss, x, ',')) {
        if (x == item) return true;
    }
    return false;
}

double median(std::vector<double> v) {
    if (v.empty()) return NAN;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/// One DYN + BRK case: the term (empty: clean), the expected name at rest (empty: nothing at rest).
struct PairCase {
    const char* id;
    const char* pattern;  ///< with {a}
    double lo, hi;
    bool random_sign;
    const char* expected;
};
constexpr PairCase kPairCases[] = {
    {"constant-torque", "torque: {a}", 0.003, 0.006, true, "constant_torque"},
    {"hinge-sensor-offset", "hinge: {a}", 2.5, 5.0, true, "hinge_sensor_offset"},
    {"current-sensor-offset", "current: {a}", 0.02, 0.05, true, ""},
    {"current-offset-dyn-names", "current: {a}", 0.08, 0.2, true, ""},
    {"friction-with-deflection", "torque: {a}*sgn(w)*abs(theta_u)", 0.004, 0.008, false, ""},
};

/// The dynbrk set: one row per pair, then the false claims on clean pairs.
void run_pairs(int runs, int clean_runs, std::mt19937_64& g, std::uint64_t& run_seed, emadiag::sim::NoiseProfile noise) {
    std::printf("\nacross DYN and BRK (case B; each pair: a DYN and a BRK run of one actuator, the same term, own noise seeds)\n");
    std::printf("(verdicts: named: found across DYN and BRK as injected; dyn+brk: named by the DYN run, the BRK run agrees;\n"
                " ok: nothing at rest injected or claimed; CLAIM: an offset at rest claimed where none was; not-cmp: not compared)\n");
    std::printf("%-26s %-28s | %-40s %-7s | %-24s | %-7s | %-15s | %-15s | %s\n", "case", "injected", "named at rest", "verdict",
                "size found (se)", "BRK z", "DYN cost mdl/with", "FDJ N m bef/aft", "time s");
    std::map<std::string, int> verdicts;
    // A DYN and a BRK run of one actuator in case B with the term (none when empty), own noise seeds.
    auto make_pair = [&](const std::string& term) {
        emadiag::sim::SimConfig dyn, brk;
        dyn.load_case = brk.load_case = emadiag::sim::LoadCase::B;
        dyn.sequence = emadiag::sim::Sequence::Dyn;
        brk.sequence = emadiag::sim::Sequence::Brk;
        dyn.noise = brk.noise = noise;
        dyn.seed = ++run_seed;
        brk.seed = ++run_seed;
        if (!term.empty()) dyn.params.terms.push_back(emadiag::sim::parse_term(term));
        brk.params.terms = dyn.params.terms;
        return std::vector<emadiag::Run>{emadiag::make_run(dyn, emadiag::sim::simulate(dyn)),
                                         emadiag::make_run(brk, emadiag::sim::simulate(brk))};
    };
    std::vector<std::pair<const PairCase*, int>> list;
    for (const auto& pc : kPairCases) list.emplace_back(&pc, runs);
    for (const auto& [pc, n] : list) {
        for (int r = 0; r < n; ++r) {
            double a = tc::uniform(g, pc->lo, pc->hi);
            if (pc->random_sign && tc::uniform(g, 0, 1) < 0.5) a = -a;
            std::string text = pc->pattern;
            char buf[32];
            std::snprintf(buf, sizeof buf, "%.6g", a);
            text.replace(text.find("{a}"), 3, buf);
            const std::vector<emadiag::Run> pair = make_pair(text);
            const auto t0 = std::chrono::steady_clock::now();
            const auto rep = emadiag::discovery::discover_runs(pair, {"dyn", "brk"});
            const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            const auto& b = rep.breakaways.at(0);
            std::string named = b.terms.empty() ? (b.significant ? "not named" : "none") : b.key;
            if (b.equivalent) named += " (~" + b.hypotheses[1].key + ")";
            std::string verdict;
            const std::string expected = pc->expected;
            const auto dyn_named = rep.reports.at(0).added_effects();
            // The library's hinge_offset effect is the hinge-moment sensor offset as a term.
            const bool dyn_has = !expected.empty() && std::any_of(dyn_named.begin(), dyn_named.end(), [&](const std::string& k) {
                return k == expected || (expected == "hinge_sensor_offset" && k == "hinge_offset");
            });
            if (!dyn_named.empty()) named += " [DYN: " + join(dyn_named) + "]";
            if (!b.problem.empty()) verdict = "not-cmp";
            else if (expected.empty()) verdict = b.terms.empty() && !b.significant ? "ok" : "CLAIM";
            else if (dyn_has && !b.significant) verdict = "dyn+brk";
            else if (b.key == expected && !b.equivalent) verdict = "named";
            else if (b.equivalent && (b.hypotheses[0].key == expected || b.hypotheses[1].key == expected)) verdict = "equiv";
            else if (!b.terms.empty()) verdict = "WRONG";
            else verdict = "missed";
            ++verdicts[verdict];
            char size[64] = "-";
            if (!b.terms.empty()) {
                const double z = (b.terms.front().coefficient - a) / b.terms.front().std_error;
                std::snprintf(size, sizeof size, "%.4g (%.2g) %+.1f se", b.terms.front().coefficient, b.terms.front().std_error, z);
            }
            const double fdj_after = b.terms.empty() ? NAN : b.hypotheses.front().fdj_nm;
            const double cost_with = b.terms.empty() ? NAN : b.hypotheses.front().dyn_cost;
            std::printf("%-26s %-28s | %-40s %-7s | %-24s | %7.2f | %6.2f %6.2f | %.4f %.4f | %.2f\n", pc->id, text.c_str(),
                        named.c_str(), verdict.c_str(), size, b.z, b.dyn_cost_model, cost_with, b.fdj_before_nm, fdj_after, secs);
            std::fflush(stdout);
        }
    }
    int claims = 0;
    for (int r = 0; r < clean_runs; ++r) {
        const auto rep = emadiag::discovery::discover_runs(make_pair(""), {"dyn", "brk"});
        const auto& b = rep.breakaways.at(0);
        if (b.significant || !b.terms.empty()) {
            ++claims;
            std::printf("clean pair %d: CLAIM %s\n", r, b.verdict.c_str());
        }
    }
    std::printf("verdicts across DYN and BRK:");
    for (const auto& [v, n] : verdicts) std::printf(" %s %d", v.c_str(), n);
    std::printf("; clean pairs: %d claims at rest in %d\n", claims, clean_runs);
}

/// The loads set: two DYN runs of one actuator, in flight (case B) and on the ground (case A) or on
/// the load rig (A-ext), with the same injected term (empty: clean).
struct LoadPairCase {
    const char* id;
    const char* pattern;
    double lo, hi;
    emadiag::sim::LoadCase other;
    std::vector<std::string> expected;  ///< acceptable names of the across-load-cases finding (empty: clean)
};

void run_load_pairs(int runs, int clean_runs, std::mt19937_64& g, std::uint64_t& run_seed, emadiag::sim::NoiseProfile noise) {
    using emadiag::sim::LoadCase;
    const std::vector<LoadPairCase> cases = {
        {"deflection-friction+A", "torque: {a}*sgn(w)*abs(theta_u)", 0.002, 0.005, LoadCase::A, {"friction_deflection"}},
        {"deflection-friction+Aext", "torque: {a}*sgn(w)*abs(theta_u)", 0.002, 0.005, LoadCase::AExt, {"friction_deflection"}},
        {"load-friction+A", "torque: {a}*sgn(w)*abs(F_R)", 0.02, 0.04, LoadCase::A, {"friction_load", "efficiency"}},
        {"load-friction+Aext", "torque: {a}*sgn(w)*abs(F_R)", 0.02, 0.04, LoadCase::AExt, {"friction_load", "efficiency"}},
        {"efficiency+A", "", 0.80, 0.83, LoadCase::A, {"efficiency", "friction_load"}},
    };
    std::printf("\nacross load cases (a flight run, case B, with a ground run, case A, or a load-rig run, A-ext; same actuator)\n");
    std::printf("(verdicts: named: the finding as injected, told apart from the rest; equiv: as injected, reported with an\n"
                " equivalent; WRONG: another; missed: the stage did not run or found nothing; CLAIM: on a clean pair)\n");
    std::printf("%-26s %-36s | %-22s %-7s | %-40s | %s\n", "case", "injected", "named", "verdict", "mean trajectory cost: best, next",
                "time s");
    std::map<std::string, int> verdicts;
    auto config = [&](LoadCase lc) {
        emadiag::sim::SimConfig c;
        c.load_case = lc;
        c.sequence = emadiag::sim::Sequence::Dyn;
        c.noise = noise;
        c.seed = ++run_seed;
        return c;
    };
    for (const auto& lc : cases) {
        for (int r = 0; r < runs; ++r) {
            const double a = tc::uniform(g, lc.lo, lc.hi);
            char buf[48];
            std::snprintf(buf, sizeof buf, "%.6g", a);
            std::string text = lc.pattern;
            emadiag::sim::SimConfig b = config(LoadCase::B), o = config(lc.other);
            if (text.empty()) {  // an efficiency below the datasheet
                text = std::string("eta_O ") + buf;
                for (auto* c : {&b, &o}) {
                    c->params.eta_o = a;
                    c->params.eta_a = emadiag::sim::eta_a_from_eta_o(a, c->params.tau);
                }
            } else {
                text.replace(text.find("{a}"), 3, buf);
                b.params.terms.push_back(emadiag::sim::parse_term(text));
                o.params.terms = b.params.terms;
            }
            const auto t0 = std::chrono::steady_clock::now();
            const auto rep = emadiag::discovery::discover_runs(
                {emadiag::make_run(b, emadiag::sim::simulate(b)), emadiag::make_run(o, emadiag::sim::simulate(o))}, {"B", "other"});
            const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            const auto& L = rep.loads;
            std::string named = L.ran ? (L.key.empty() ? "none" : L.key) : "not run";
            if (L.equivalent) named += " (~" + L.hypotheses[1].key + ")";
            auto ok = [&](const std::string& k) { return std::find(lc.expected.begin(), lc.expected.end(), k) != lc.expected.end(); };
            std::string verdict;
            if (!L.ran || L.key.empty()) verdict = "missed";
            else if (ok(L.key) && (!L.equivalent || ok(L.hypotheses[1].key))) verdict = L.equivalent ? "equiv" : "named";
            else if (L.equivalent && (ok(L.key) || ok(L.hypotheses[1].key))) verdict = "equiv";
            else verdict = "WRONG";
            ++verdicts[verdict];
            char costs[64] = "-";
            if (L.hypotheses.size() >= 2) {
                std::snprintf(costs, sizeof costs, "%.3g, %.3g (%s)", L.hypotheses[0].mean_cost, L.hypotheses[1].mean_cost,
                              L.hypotheses[1].key.c_str());
            }
            std::printf("%-26s %-36s | %-22s %-7s | %-40s | %.2f\n", lc.id, text.c_str(), named.c_str(), verdict.c_str(), costs, secs);
            std::fflush(stdout);
        }
    }
    int claims = 0;
    for (int r = 0; r < clean_runs; ++r) {
        emadiag::sim::SimConfig b = config(LoadCase::B), o = config(r % 2 ? LoadCase::A : LoadCase::AExt);
        const auto rep = emadiag::discovery::discover_runs(
            {emadiag::make_run(b, emadiag::sim::simulate(b)), emadiag::make_run(o, emadiag::sim::simulate(o))}, {"B", "other"});
        if (rep.loads.ran && !rep.loads.key.empty()) {
            ++claims;
            std::printf("clean load pair %d: CLAIM %s\n", r, rep.loads.verdict.c_str());
        }
    }
    std::printf("verdicts across load cases:");
    for (const auto& [v, n] : verdicts) std::printf(" %s %d", v.c_str(), n);
    std::printf("; clean pairs: %d claims in %d\n", claims, clean_runs);
}

}  // namespace

int main(int argc, char** argv) {
    const char* usage =
        "usage: discovery_bench [runs_per_case=1] [seed=11] [noise=typical|none] "
        "[sets=library,dev,heldout,clean (also dynbrk, loads)] [clean_runs=10] [plot_dir=]\n";
    if (argc > 1 && (std::string(argv[1]) == "-h" || std::string(argv[1]) == "--help")) {
        std::fputs(usage, stdout);
        return 0;
    }
    int runs = 1, clean_runs = 10;
    std::uint64_t seed = 11;
    try {
        if (argc > 1) runs = std::stoi(argv[1]);
        if (argc > 2) seed = std::stoull(argv[2]);
        if (argc > 5) clean_runs = std::stoi(argv[5]);
    } catch (const std::exception&) {
        std::fprintf(stderr, "discovery_bench: runs_per_case, seed and clean_runs are whole numbers\n%s", usage);
        return 2;
    }
    const std::string noise = argc > 3 ? argv[3] : "typical";
    const std::string sets = argc > 4 ? argv[4] : "library,dev,heldout,clean";
    const std::string plot_dir = argc > 6 ? argv[6] : "";
    std::printf("discovery_bench: %d run(s) per case, seed %llu, noise %s, sets %s, %d clean runs; DYN case B 0.5 s\n",
                runs, static_cast<unsigned long long>(seed), noise.c_str(), sets.c_str(), clean_runs);
    std::mt19937_64 g(seed);
    std::vector<Case> cases;
    if (listed(sets, "library")) {
        for (const char* k : {"viscous", "stribeck", "spall", "ripple", "current_gain_error", "hinge_offset", "inertia"}) {
            for (int r = 0; r < runs; ++r) cases.push_back(library_case(k, g));
        }
    }
    auto add_injected = [&](const char* set, const std::vector<tc::InjectedCase>& list) {
        for (const auto& ic : list) {
            for (int r = 0; r < runs; ++r) {
                Case c;
                c.set = set;
                c.id = ic.id;
                c.expected = ic.expected_name;
                c.variables = ic.expected_variable;
                const emadiag::sim::Term t = tc::draw_term(ic, g);
                c.config = tc::case_config(ic, t, emadiag::sim::NoiseProfile::None, 0);
                c.injected = t.text();
                cases.push_back(c);
            }
        }
    };
    if (listed(sets, "dev")) add_injected("dev", tc::kDevelopmentCases);
    if (listed(sets, "heldout")) add_injected("heldout", tc::kHeldOutCases);
    if (listed(sets, "clean")) {
        for (int r = 0; r < clean_runs; ++r) {
            Case c;
            c.set = "clean";
            c.id = "clean";
            c.expected = "";
            c.injected = "-";
            cases.push_back(c);
        }
    }
    if (listed(sets, "dynbrk")) {
        // Its own draws, so listing it leaves the other sets' cases as they were.
        std::mt19937_64 gp(seed + 1);
        std::uint64_t pair_seed = seed * 1000 + 900;
        run_pairs(runs, clean_runs, gp, pair_seed, emadiag::sim::parse_noise(noise));
    }
    if (listed(sets, "loads")) {
        std::mt19937_64 gl(seed + 2);
        std::uint64_t load_seed = seed * 1000 + 700;
        run_load_pairs(runs, clean_runs, gl, load_seed, emadiag::sim::parse_noise(noise));
    }
    std::printf("\n%-8s %-26s %-44s | %-44s %-8s | %-17s | %-13s | %-15s | %s\n", "set", "case", "injected", "named",
                "verdict", "current A bef/aft", "traj cost b/a", "FDJ N m bef/aft", "time s (wall, cpu)");
    std::map<std::string, std::map<std::string, int>> verdicts;
    std::vector<std::string> coefficient_lines;
    int coefficients = 0, coefficients_within = 0;
    std::vector<double> times, cpu_times;
    int added_rows = 0, current_goal_met = 0, fdj_toward = 0;
    std::vector<std::string> current_goal_misses, fdj_away;
    std::uint64_t run_seed = seed * 1000;
    for (auto& c : cases) {
        c.config.noise = emadiag::sim::parse_noise(noise);
        c.config.seed = ++run_seed;
        const auto run = emadiag::make_run(c.config, emadiag::sim::simulate(c.config));
        std::string named = "error", verdict = "error";
        double i0 = NAN, i1 = NAN, c0 = NAN, c1 = NAN, f0 = NAN, f1 = NAN, secs = NAN, cpu = NAN;
        try {
            const auto t0 = std::chrono::steady_clock::now();
            const std::clock_t cpu0 = std::clock();
            const DiscoveryReport rep = emadiag::discovery::discover(run);
            cpu = static_cast<double>(std::clock() - cpu0) / CLOCKS_PER_SEC;
            secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            times.push_back(secs);
            cpu_times.push_back(cpu);
            if (const char* dir = std::getenv("DISCOVERY_BENCH_JSON")) {
                std::ofstream(std::string(dir) + "/" + c.id + "_" + std::to_string(c.config.seed) + ".json")
                    << rep.to_json().dump(1);
            }
            const auto added = rep.added_effects();
            named = added.empty() ? "none" : join(added);
            bool equivalent_with_expected = false;
            for (const auto& st : rep.steps) {
                if (!st.equivalent) continue;
                named += " (~" + st.hypotheses[1].key + ")";
                for (const auto& h : st.hypotheses) equivalent_with_expected = equivalent_with_expected || h.key == c.expected;
            }
            if (rep.efficiency.equivalent || rep.efficiency.favoured) {
                named += std::string(" (") + (rep.efficiency.equivalent ? "~" : ">") + "eta:" + rep.efficiency.key + ")";
                equivalent_with_expected = equivalent_with_expected || rep.efficiency.key == c.expected;
            }
            const auto* u = rep.unexplained();
            std::string uvar;
            if (u != nullptr) {
                uvar = u->dependence.empty() ? "?" : u->dependence.front().variable;
                named += " | unexplained " + u->channel + " ~ " + uvar;
                if (!plot_dir.empty()) {
                    emadiag::discovery::ResidualPlot pl;
                    pl.title = c.id + ": unexplained " + u->channel + " residual";
                    pl.x_label = uvar;
                    pl.y_label = u->channel + " residual (" + u->unit + ")";
                    pl.x = u->x;
                    pl.y = u->y;
                    pl.floor = u->floor;
                    std::ofstream(plot_dir + "/" + c.id + "_" + std::to_string(c.config.seed) + ".svg")
                        << emadiag::discovery::residual_svg(pl);
                }
            }
            const bool expected_named = std::find(added.begin(), added.end(), c.expected) != added.end();
            const std::size_t others = added.size() - (expected_named ? 1 : 0);
            if (c.set == "clean") {
                verdict = added.empty() && u == nullptr ? "ok" : "CLAIM";
            } else if (expected_named && others == 0) {
                verdict = "named";
            } else if (others > 0 && !equivalent_with_expected) {
                verdict = expected_named ? "named+X" : "WRONG";
            } else if (equivalent_with_expected) {
                verdict = "equiv";
            } else if (u != nullptr && listed(c.variables, uvar)) {
                verdict = "unexpl-ok";
            } else if (u != nullptr) {
                verdict = "unexpl-var";
            } else {
                verdict = "missed";
            }
            // Library effects: each fitted coefficient against the truth, in its standard errors.
            if (c.set == "library" && expected_named) {
                for (const auto& [key, truth] : c.truth) {
                    if (key == "ripple_periods") continue;  // scanned, not fitted
                    const std::string field = emadiag::discovery::effect_field(key);
                    for (const auto& t : rep.model.terms) {
                        if (t.effect != field) continue;
                        const double z = t.std_error > 0 ? std::abs(t.value - truth) / t.std_error : INFINITY;
                        ++coefficients;
                        coefficients_within += z <= kWithinSe ? 1 : 0;
                        char b[200];
                        std::snprintf(b, sizeof b, "  %-20s %-20s truth %-11.5g fitted %-11.5g +/- %-9.3g error %6.2f se %s",
                                      c.id.c_str(), key.c_str(), truth, t.value, t.std_error, z,
                                      z <= kWithinSe ? "within" : "OUTSIDE");
                        coefficient_lines.emplace_back(b);
                    }
                }
            }
            i0 = rep.model.error_before.current_rms_a;
            i1 = rep.model.error_after.current_rms_a;
            c0 = rep.trajectory_before.cost;
            c1 = rep.trajectory_after.cost;
            f0 = rep.baseline_health.front().value;
            f1 = rep.model.health.front().value;
            // Issue 10's goals where a term is added: the current error to 0.7 x before or within 10 %
            // of the noise floor; FDJ toward the truth.
            if (c.set != "clean" && !added.empty()) {
                ++added_rows;
                if (i1 <= kCurrentGoalRatio * i0 || i1 <= kCurrentGoalFloor * rep.floor.current_a) ++current_goal_met;
                else current_goal_misses.push_back(c.id + " " + std::to_string(i0) + " -> " + std::to_string(i1) + " A (floor " +
                                                   std::to_string(rep.floor.current_a) + ")");
                const double se = rep.model.health.front().std_error;
                if (std::abs(f1 - kTrueFdjNm) <= std::abs(f0 - kTrueFdjNm)) ++fdj_toward;
                else {
                    char b[200];
                    std::snprintf(b, sizeof b, "%s |FDJ - truth| %.4f -> %.4f N m (%.2f se)", c.id.c_str(), std::abs(f0 - kTrueFdjNm),
                                  std::abs(f1 - kTrueFdjNm), se > 0 ? std::abs(f1 - kTrueFdjNm) / se : INFINITY);
                    fdj_away.emplace_back(b);
                }
            }
        } catch (const std::exception& e) {
            named = std::string("error: ") + e.what();
        }
        ++verdicts[c.set][verdict];
        std::printf("%-8s %-26s %-44s | %-44s %-8s | %.4f %.4f | %6.2f %6.2f | %.4f %.4f | %.2f (cpu %.2f)\n",
                    c.set.c_str(), c.id.c_str(), c.injected.c_str(), named.c_str(), verdict.c_str(), i0, i1, c0, c1, f0,
                    f1, secs, cpu);
        std::fflush(stdout);
    }
    if (!coefficient_lines.empty()) {
        std::printf("\nlibrary effects named: fitted coefficients against the truth (within: |error| <= %.2f se)\n", kWithinSe);
        for (const auto& l : coefficient_lines) std::printf("%s\n", l.c_str());
        std::printf("  %d of %d coefficients within their uncertainty\n", coefficients_within, coefficients);
    }
    std::printf("\ngoal (issue 10), rows where something was added (not clean): the current error to %.1f x before or within "
                "%.0f %% of the noise floor on %d of %d; FDJ toward the truth on %d of %d\n",
                kCurrentGoalRatio, 100.0 * (kCurrentGoalFloor - 1.0), current_goal_met, added_rows, fdj_toward, added_rows);
    for (const auto& m : current_goal_misses) std::printf("  current error goal missed: %s\n", m.c_str());
    for (const auto& m : fdj_away) std::printf("  FDJ away from the truth: %s\n", m.c_str());
    std::printf("\nverdicts per set (named: the expected name only; equiv: reported as one of two equivalent hypotheses;\n"
                "unexpl-ok: unexplained structure against an expected variable; WRONG: another name and not the expected;\n"
                "named+X: the expected name and another; CLAIM: anything claimed on a clean run)\n");
    for (const auto& [set, m] : verdicts) {
        std::printf("  %-8s", set.c_str());
        for (const auto& [v, n] : m) std::printf(" %s %d", v.c_str(), n);
        std::printf("\n");
    }
    std::printf("time of one discover(): median %.2f s, max %.2f s wall; CPU median %.2f s, max %.2f s; over %zu runs\n",
                median(times), times.empty() ? NAN : *std::max_element(times.begin(), times.end()), median(cpu_times),
                cpu_times.empty() ? NAN : *std::max_element(cpu_times.begin(), cpu_times.end()), times.size());
    const std::size_t over = static_cast<std::size_t>(
        std::count_if(cpu_times.begin(), cpu_times.end(), [](double c) { return c > kGoalCpuS; }));
    std::printf("goal (issue 10): CPU of one discover() <= %.0f s on every run: %s (%zu of %zu runs above; CPU is the\n"
                "process's, summed over its threads; wall depends on the machine's load)\n",
                kGoalCpuS, over == 0 ? "met" : "NOT met", over, cpu_times.size());
    return 0;
}
