#include "research/paper_tables.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/dataset.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/nn_trainer.hpp"
#include "estimation/physics_estimator.hpp"
#include "emadiag/sim/physics.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <optional>
#include <random>
#include <sstream>

namespace emadiag {
namespace {

using sim::kCaseAHingeNm;  // ema-reference.md section 4, case A
constexpr int kFloorSamples = 20000;
constexpr int kFloorGrid = 2001;
constexpr int kTenPredictions = 10;
constexpr double kImprovedGoal = 1e-10;  // "ours+": train past the paper's goal, stop on validation

std::string sci(double v) {
    if (!std::isfinite(v)) return "n/a";
    char b[32];
    std::snprintf(b, sizeof b, "%.3e", v);
    return b;
}
std::string fix(double v, int digits) {
    if (!std::isfinite(v)) return "n/a";
    char b[32];
    std::snprintf(b, sizeof b, "%.*f", digits, v);
    return b;
}
std::string secs(double v) { return fix(v, v < 10 ? 2 : 1) + " s"; }
std::string pct(double v) { return fix(100.0 * v, 1) + " %"; }

/// FNV-1a: a seed offset per dataset key that is the same with every standard library
/// (std::hash is not).
std::uint64_t fnv1a(const std::string& s) {
    std::uint64_t h = 14695981039346656037ull;
    for (unsigned char c : s) {
        h ^= c;
        h *= 1099511628211ull;
    }
    return h;
}

double now_s() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

/// The physics estimator on a set of runs, scored like the network.
struct PhysicsEval {
    double mse = std::numeric_limits<double>::quiet_NaN();
    std::vector<double> mse_per_output;
    double coverage95 = std::numeric_limits<double>::quiet_NaN();
    int runs = 0;
    int failures = 0;      ///< threw, or did not report an output the network predicts
    std::string first_failure;
    double time_per_run_s = 0;
    std::vector<std::vector<double>> predicted;  ///< per output, per run (normalised; NaN on failure)
};

PhysicsEval eval_physics(const Dataset& d, const std::vector<int>& idx, const std::vector<std::string>& outputs) {
    PhysicsEval e;
    e.predicted.assign(outputs.size(), std::vector<double>(idx.size(), std::numeric_limits<double>::quiet_NaN()));
    std::vector<double> sq(outputs.size(), 0.0);
    int ok = 0, covered = 0, pairs = 0;
    const double t0 = now_s();
    for (std::size_t k = 0; k < idx.size(); ++k) {
        const auto i = static_cast<std::size_t>(idx[k]);
        try {
            const HealthEstimate h = estimate_physics(check_run(d.run(i)));
            std::vector<double> u(outputs.size());
            std::vector<double> half(outputs.size());
            for (std::size_t o = 0; o < outputs.size(); ++o) {
                const ParameterEstimate* p = h.find(outputs[o]);
                if (p == nullptr || !p->value) throw EmadiagError("no value for " + outputs[o]);
                const HealthRange r = health_range(outputs[o]);
                u[o] = r.normalise(*p->value);
                half[o] = kZ95 * p->std_error / (r.hi - r.lo);
            }
            for (std::size_t o = 0; o < outputs.size(); ++o) {
                const double truth = health_range(outputs[o]).normalise(d.runs[i].labels.get(outputs[o]));
                const double err = u[o] - truth;
                sq[o] += err * err;
                e.predicted[o][k] = u[o];
                ++pairs;
                if (std::abs(err) <= half[o]) ++covered;
            }
            ++ok;
        } catch (const std::exception& ex) {
            if (e.failures == 0) e.first_failure = ex.what();
            ++e.failures;
        }
    }
    e.time_per_run_s = idx.empty() ? 0 : (now_s() - t0) / static_cast<double>(idx.size());
    e.runs = static_cast<int>(idx.size());
    if (ok > 0) {
        double total = 0;
        for (double s : sq) {
            e.mse_per_output.push_back(s / ok);
            total += s / ok;
        }
        e.mse = total / static_cast<double>(outputs.size());
        e.coverage95 = static_cast<double>(covered) / pairs;
    }
    return e;
}

/// Coverage and MSE of a trained model on runs it never saw (a fresh dataset).
struct FreshCheck {
    double coverage95 = std::numeric_limits<double>::quiet_NaN();
    double mse = std::numeric_limits<double>::quiet_NaN();
    long pairs = 0;
};

FreshCheck fresh_check(const NetworkModel& model, const Dataset& fresh, unsigned threads) {
    const FeatureSet f = build_features(fresh, model.spec, 0, threads);
    const Eigen::MatrixXd y = model.network.forward(model.input_norm.apply(f.x));
    FreshCheck c;
    long covered = 0;
    double sq = 0;
    for (Eigen::Index o = 0; o < y.rows(); ++o) {
        const double half = kZ95 * model.std_error_normalised[static_cast<std::size_t>(o)];
        for (Eigen::Index k = 0; k < y.cols(); ++k) {
            const double e = from_internal(y(o, k)) - f.u(o, k);
            sq += e * e;
            if (std::abs(e) <= half) ++covered;
            ++c.pairs;
        }
    }
    c.coverage95 = static_cast<double>(covered) / static_cast<double>(c.pairs);
    c.mse = sq / static_cast<double>(c.pairs);
    return c;
}

struct NetRow {
    TrainReport rep;
    PhysicsEval physics;
};

struct Context {
    PaperTablesOptions opt;
    PaperTablesLog log;
    std::map<std::string, Dataset> clean;  // key: case/sequence
    std::vector<std::string> notes;

    void say(const std::string& s) const {
        if (log) log(s);
    }

    // Sizes shrink in quick mode so a test runs every table in seconds.
    [[nodiscard]] int runs(int n) const { return opt.quick ? std::min(n, 40) : n; }
    [[nodiscard]] int steps(int n) const { return opt.quick ? std::min(n, 50) : n; }
    [[nodiscard]] int neurons(int n) const { return opt.quick ? std::min(n, 5) : n; }

    const Dataset& dataset(sim::LoadCase c, sim::Sequence s, int count) {
        const std::string key = sim::to_string(c) + "/" + sim::to_string(s);
        auto it = clean.find(key);
        if (it == clean.end() || static_cast<int>(it->second.runs.size()) < count) {
            DatasetSpec spec;
            spec.load_case = c;
            spec.sequence = s;
            spec.count = count;
            spec.seed = opt.seed + fnv1a(key) % 1000;
            const double t0 = now_s();
            Dataset d = generate_dataset(spec, opt.threads);
            say("simulated " + key + ": " + std::to_string(d.filter.simulated) + " runs, " +
                std::to_string(d.filter.accepted) + " accepted, " + secs(now_s() - t0));
            it = clean.insert_or_assign(key, std::move(d)).first;
        }
        return it->second;
    }

    NetRow train(const Dataset& d, NetworkSpec spec, int runs_used, double goal = 1e-6) {
        TrainOptions t;
        t.spec = std::move(spec);
        t.split_seed = opt.seed;
        t.init_seed = opt.seed + 1;
        t.scg.goal = goal;
        if (opt.quick) t.scg.max_epochs = 60;
        NetRow row;
        const FeatureSet f = build_features(d, t.spec, runs_used, opt.threads);
        row.rep = train_network(f, t);
        std::vector<int> test;
        for (int i : row.rep.split.test) test.push_back(i);
        if (opt.physics) row.physics = eval_physics(d, test, t.spec.outputs);
        say("trained " + sim::to_string(t.spec.load_case) + "/" + sim::to_string(t.spec.sequence) + " " + sim::to_string(d.spec.noise) + " " +
            std::to_string(t.spec.timesteps) + "x" + std::to_string(runs_used) + "x" +
            std::to_string(t.spec.hidden_neurons) + ": test MSE " + sci(row.rep.mse.test) + " in " +
            secs(row.rep.train_time_s) + ", physics " + sci(row.physics.mse));
        return row;
    }
};

NetworkSpec make_spec(const std::string& c, const std::string& s, int timesteps, int neurons,
                      std::vector<std::string> outputs) {
    NetworkSpec spec;
    spec.load_case = sim::parse_load_case(c);
    spec.sequence = sim::parse_sequence(s);
    spec.timesteps = timesteps;
    spec.hidden_neurons = neurons;
    spec.outputs = std::move(outputs);
    return spec;
}

std::string physics_cell(const PhysicsEval& p) {
    if (p.runs == 0) return "not run";
    std::string s = sci(p.mse);
    if (p.failures > 0) s += " (" + std::to_string(p.failures) + "/" + std::to_string(p.runs) + " failed)";
    return s;
}

/// Table of train/validation/test for noise none and typical, with the physics estimator.
void performance_table(std::ostringstream& md, const double paper[3], const NetRow& none, const NetRow& typical) {
    md << "| Performance (MSE) | Paper | Network, noise none | Network, noise typical | Physics, noise none | Physics, noise typical |\n"
          "|---|---|---|---|---|---|\n";
    md << "| Training | " << sci(paper[0]) << " | " << sci(none.rep.mse.train) << " | " << sci(typical.rep.mse.train)
       << " | - | - |\n";
    md << "| Validation | " << sci(paper[1]) << " | " << sci(none.rep.mse.validation) << " | "
       << sci(typical.rep.mse.validation) << " | - | - |\n";
    md << "| Test | " << sci(paper[2]) << " | " << sci(none.rep.mse.test) << " | " << sci(typical.rep.mse.test) << " | "
       << physics_cell(none.physics) << " | " << physics_cell(typical.physics) << " |\n";
    const auto& outs = none.rep.model.spec.outputs;
    if (outs.size() > 1) {
        for (std::size_t o = 0; o < outs.size(); ++o) {
            const auto phys = [&](const PhysicsEval& p) {
                return o < p.mse_per_output.size() ? sci(p.mse_per_output[o]) : std::string("n/a");
            };
            md << "| Test, " << outs[o] << " only | - | " << sci(none.rep.mse.test_per_output[o]) << " | "
               << sci(typical.rep.mse.test_per_output[o]) << " | " << phys(none.physics) << " | "
               << phys(typical.physics) << " |\n";
        }
    }
    md << "| Training time | - | " << secs(none.rep.train_time_s) << " (" << none.rep.scg.epochs << " epochs, stop "
       << none.rep.scg.stop_reason << ") | " << secs(typical.rep.train_time_s) << " (" << typical.rep.scg.epochs
       << " epochs, stop " << typical.rep.scg.stop_reason << ") | " << fix(1e3 * none.physics.time_per_run_s, 1)
       << " ms per run | " << fix(1e3 * typical.physics.time_per_run_s, 1) << " ms per run |\n";
    md << "| 95 % interval coverage (test runs) | - | " << pct(none.rep.test_coverage95) << " | "
       << pct(typical.rep.test_coverage95) << " | " << pct(none.physics.coverage95) << " | "
       << pct(typical.physics.coverage95) << " |\n\n";
}

struct PaperPrediction {
    double target, predicted, rel_pct;
};

/// Ten random test predictions (paper Tables 3 and 6), normalised, relative error |p - t| / t.
void ten_predictions(std::ostringstream& md, const NetRow& row, const std::vector<std::vector<PaperPrediction>>& paper,
                     std::uint64_t seed) {
    const auto& outs = row.rep.model.spec.outputs;
    const auto n = static_cast<int>(row.rep.test_target.cols());
    std::mt19937_64 rng(seed);
    std::vector<int> idx(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) idx[static_cast<std::size_t>(i)] = i;
    for (std::size_t i = idx.size(); i > 1; --i) {
        const auto j = std::min(static_cast<std::size_t>(uniform01(rng()) * static_cast<double>(i)), i - 1);
        std::swap(idx[i - 1], idx[j]);
    }
    idx.resize(std::min<std::size_t>(idx.size(), kTenPredictions));
    for (std::size_t o = 0; o < outs.size(); ++o) {
        md << "Parameter " << outs[o] << " (normalised; relative error = |predicted - target| / target):\n\n";
        md << "| Paper target | Paper predicted | Paper rel. error | Our target | Network predicted | Network rel. error | "
              "Physics predicted | Physics rel. error |\n|---|---|---|---|---|---|---|---|\n";
        for (std::size_t k = 0; k < idx.size(); ++k) {
            const auto c = static_cast<Eigen::Index>(idx[k]);
            const double t = row.rep.test_target(static_cast<Eigen::Index>(o), c);
            const double p = row.rep.test_predicted(static_cast<Eigen::Index>(o), c);
            double phys = std::numeric_limits<double>::quiet_NaN();
            if (o < row.physics.predicted.size()) phys = row.physics.predicted[o][static_cast<std::size_t>(c)];
            const auto rel = [t](double v) { return std::isfinite(v) ? fix(100.0 * std::abs(v - t) / t, 2) + " %" : "n/a"; };
            if (o < paper.size() && k < paper[o].size()) {
                md << "| " << fix(paper[o][k].target, 4) << " | " << fix(paper[o][k].predicted, 4) << " | "
                   << fix(paper[o][k].rel_pct, 2) << " % ";
            } else {
                md << "| - | - | - ";
            }
            md << "| " << fix(t, 4) << " | " << fix(p, 4) << " | " << rel(p) << " | " << fix(phys, 4) << " | " << rel(phys)
               << " |\n";
        }
        md << '\n';
    }
}

/// The network rows of every table, for the goals and the calibration summary.
struct TableRows {
    const NetRow &a_none, &a_typ;
    const std::optional<NetRow> &b5_none, &b5_typ;
    const NetRow &plus_none, &plus_typ, &smooth_none, &smooth_typ, &ax_none, &ax_typ, &sw_none, &sw_typ;
};

/// Table 2's paragraph on the eta confound floor of case A.
void confound_floor_paragraph(std::ostringstream& md, const PaperTablesOptions& options, const Dataset& a_clean, const NetRow& a_none,
                              const ConfoundFloor& floor) {
    md << "**The eta confound floor.** In case A the load is constant (H = 5 N m, F_R = " << fix(kCaseAHingeNm / a_clean.constants.tau * 1e3, 3)
       << " mN m), so eq. (5) gives T_R = FDJ + c(eta) |F_R| while slipping, with c = 1/eta_O - 1 opposing and 1 - eta_A "
          "aiding; eq. (4) makes the two equal to within "
       << sci(floor.c_difference_max)
       << " N m, far below any measurement. FDJ and eta trade off: the best possible predictor is E[FDJ | s] with s = "
          "FDJ + c(eta)|F_R|, eta_A uniform and unobserved. Its normalised MSE (Monte Carlo, "
       << (options.quick ? 2000 : kFloorSamples) << " draws, posterior on a " << kFloorGrid
       << "-point eta_A grid) is the floor: **" << sci(floor.mse) << "**. Goal: within 1.5x of it, i.e. <= "
       << sci(1.5 * floor.mse) << ". Network, noise none: " << sci(a_none.rep.mse.test) << " = "
       << fix(a_none.rep.mse.test / floor.mse, 2) << "x the floor; physics: " << sci(a_none.physics.mse) << " = "
       << fix(a_none.physics.mse / floor.mse, 2) << "x. (With " << a_none.rep.split.test.size()
       << " test runs, the sampling spread of a test MSE is itself about +/-" << fix(100.0 * std::sqrt(2.0 / static_cast<double>(a_none.rep.split.test.size())), 0)
       << " %.)\n\n";
}

/// The goals of issue 4 part 7 against the best method of each case.
void goals_section(std::ostringstream& md, const TableRows& rows, const ConfoundFloor& floor) {
    const NetRow &a_none = rows.a_none, &plus_none = rows.plus_none, &plus_typ = rows.plus_typ, &smooth_none = rows.smooth_none,
                 &smooth_typ = rows.smooth_typ, &ax_none = rows.ax_none;
    const std::optional<NetRow> &b5_none = rows.b5_none, &b5_typ = rows.b5_typ;
    const auto best = [](std::initializer_list<std::pair<const char*, double>> c) {
        std::pair<std::string, double> b{"none", std::numeric_limits<double>::infinity()};
        for (const auto& [n, v] : c) {
            if (std::isfinite(v) && v < b.second) b = {n, v};
        }
        return b;
    };
    const auto b_best_none = best({{"network (paper setting)", b5_none->rep.mse.test},
                                   {"network+", plus_none.rep.mse.test},
                                   {"network~", smooth_none.rep.mse.test},
                                   {"physics", b5_none->physics.mse}});
    const auto b_best_typ = best({{"network (paper setting)", b5_typ->rep.mse.test},
                                  {"network+", plus_typ.rep.mse.test},
                                  {"network~", smooth_typ.rep.mse.test},
                                  {"physics", b5_typ->physics.mse}});
    const auto a_best = best({{"network", a_none.rep.mse.test}, {"physics", a_none.physics.mse}});
    const double ax_eta_phys = ax_none.physics.mse_per_output.size() > 1 ? ax_none.physics.mse_per_output[1]
                                                                          : std::numeric_limits<double>::quiet_NaN();
    const auto ax_best = best({{"network", ax_none.rep.mse.test_per_output[1]}, {"physics", ax_eta_phys}});
    const auto verdict = [](bool met) { return met ? "met" : "**not met**"; };
    md << "## Goals (issue 4 part 7)\n\n"
       << "| What | The paper | Goal | Ours (best method) | Met |\n|---|---|---|---|---|\n"
       << "| Case B, paper's setting, noise none | 2.601e-06 | <= 2.6e-07 | " << sci(b_best_none.second) << " ("
       << b_best_none.first << ") | " << verdict(b_best_none.second <= 2.6e-7) << " |\n"
       << "| Case B, paper's setting, noise typical | - | report | " << sci(b_best_typ.second) << " (" << b_best_typ.first
       << ") | - |\n"
       << "| Case A FDJ, noise none | 2.453e-04 | <= 1.5 x floor = " << sci(1.5 * floor.mse) << " | " << sci(a_best.second)
       << " (" << a_best.first << "; " << fix(a_best.second / floor.mse, 2) << "x floor) | "
       << verdict(a_best.second <= 1.5 * floor.mse) << " |\n"
       << "| A-ext eta_O, noise none | 5.542e-04 (both outputs) | <= 5.5e-06 | " << sci(ax_best.second) << " ("
       << ax_best.first << ") | " << verdict(ax_best.second <= 5.5e-6) << " |\n\n";
}

/// The calibration of every network's uncertainty: its test runs and a fresh dataset per case.
void calibration_section(std::ostringstream& md, Context& cx, const TableRows& rows) {
    const PaperTablesOptions& options = cx.opt;
    const NetRow &a_none = rows.a_none, &a_typ = rows.a_typ, &plus_none = rows.plus_none, &plus_typ = rows.plus_typ,
                 &smooth_none = rows.smooth_none, &smooth_typ = rows.smooth_typ, &ax_none = rows.ax_none, &ax_typ = rows.ax_typ,
                 &sw_none = rows.sw_none, &sw_typ = rows.sw_typ;
    const std::optional<NetRow> &b5_none = rows.b5_none, &b5_typ = rows.b5_typ;
    // Calibration summary over every network row of the paper's settings.
    md << "## Calibration of the network's uncertainty\n\n"
       << "Each network's per-output standard error is calibrated on its validation runs (split-conformal 95 % "
          "quantile of |residual| / 1.96) and checked on its test runs, which it never saw. Goal: the 95 % "
          "intervals cover the truth in 90 to 98 % of test runs.\n\n"
       << "A second check uses a fresh dataset of " << cx.runs(1000)
       << " runs per case (another seed), simulated after training.\n\n"
       << "| Network | Test pairs | Coverage, none | Coverage, typical | Fresh pairs | Fresh coverage, none | Fresh coverage, typical |\n"
          "|---|---|---|---|---|---|---|\n";
    long fresh_covered = 0, fresh_pairs = 0;
    std::map<std::string, std::pair<Dataset, Dataset>> fresh;  // key case/sequence: clean, typical
    const auto cov_row = [&](const char* name, const NetRow& n, const NetRow& t) {
        const std::string key = sim::to_string(n.rep.model.spec.load_case) + "/" + sim::to_string(n.rep.model.spec.sequence);
        if (fresh.find(key) == fresh.end()) {
            DatasetSpec spec;
            spec.load_case = n.rep.model.spec.load_case;
            spec.sequence = n.rep.model.spec.sequence;
            spec.count = cx.runs(1000);
            spec.seed = options.seed + 7777 + fnv1a(key) % 1000;
            Dataset clean = generate_dataset(spec, options.threads);
            Dataset noisy = clean.with_noise(sim::NoiseProfile::Typical);
            fresh.emplace(key, std::make_pair(std::move(clean), std::move(noisy)));
        }
        const auto& [clean, noisy] = fresh.at(key);
        const FreshCheck fn = fresh_check(n.rep.model, clean, options.threads);
        const FreshCheck ft = fresh_check(t.rep.model, noisy, options.threads);
        fresh_covered += std::lround(fn.coverage95 * static_cast<double>(fn.pairs)) +
                         std::lround(ft.coverage95 * static_cast<double>(ft.pairs));
        fresh_pairs += fn.pairs + ft.pairs;
        md << "| " << name << " | " << n.rep.test_predicted.size() << " | " << pct(n.rep.test_coverage95) << " | "
           << pct(t.rep.test_coverage95) << " | " << fn.pairs << " | " << pct(fn.coverage95) << " | "
           << pct(ft.coverage95) << " |\n";
    };
    cov_row("Table 2 (case A)", a_none, a_typ);
    cov_row("Table 5 (case B)", *b5_none, *b5_typ);
    cov_row("Network+ (case B)", plus_none, plus_typ);
    cov_row("Network~ (case B)", smooth_none, smooth_typ);
    cov_row("Table 7 (A-ext)", ax_none, ax_typ);
    cov_row("Table 8 (sweep)", sw_none, sw_typ);
    {
        double covered = 0, pairs = 0;
        const std::vector<const NetRow*> all = {&a_none, &a_typ, &*b5_none, &*b5_typ, &plus_none, &plus_typ, &smooth_none, &smooth_typ, &ax_none, &ax_typ, &sw_none, &sw_typ};
        for (const NetRow* r : all) {
            const auto n = static_cast<double>(r->rep.test_predicted.size());
            covered += r->rep.test_coverage95 * n;
            pairs += n;
        }
        md << "| **All of the above, pooled (none and typical)** | " << static_cast<long>(pairs) << " | "
           << pct(covered / pairs) << " | | " << fresh_pairs << " | "
           << pct(static_cast<double>(fresh_covered) / static_cast<double>(fresh_pairs)) << " | |\n\n";
    }
}

}  // namespace

ConfoundFloor case_a_fdj_floor(double hinge_moment_nm, double tau, int samples, std::uint64_t seed) {
    if (samples < 1) throw EmadiagError("floor samples " + std::to_string(samples) + " must be positive");
    const double f_r = std::abs(hinge_moment_nm / tau);  // F_R = H / tau (section 2)
    const HealthRange fdj = health_range(kParamFdj);
    const HealthRange eta_a = health_range(kParamEtaA);
    ConfoundFloor floor;
    std::vector<double> c(kFloorGrid);
    for (int g = 0; g < kFloorGrid; ++g) {
        const double ea = eta_a.denormalise(static_cast<double>(g) / (kFloorGrid - 1));
        const double eo = sim::eta_o_from_eta_a(ea, tau);
        c[static_cast<std::size_t>(g)] = sim::load_coefficient_opposing(eo) * f_r;  // eq. (5), opposing
        floor.c_difference_max =
            std::max(floor.c_difference_max, std::abs(sim::load_coefficient_opposing(eo) - sim::load_coefficient_aiding(ea)) * f_r);
    }
    std::mt19937_64 rng(seed);
    double sum = 0;
    for (int k = 0; k < samples; ++k) {
        const double f = fdj.denormalise(uniform01(rng()));
        const double ea = eta_a.denormalise(uniform01(rng()));
        const double s = f + sim::load_coefficient_opposing(sim::eta_o_from_eta_a(ea, tau)) * f_r;
        // Posterior over the eta_A grid is uniform where s - c(eta) is an admissible FDJ.
        double m = 0;
        int n = 0;
        for (double cg : c) {
            const double cand = s - cg;
            if (cand >= fdj.lo && cand <= fdj.hi) {
                m += cand;
                ++n;
            }
        }
        const double est = n > 0 ? m / n : f;
        const double e = fdj.normalise(est) - fdj.normalise(f);
        sum += e * e;
    }
    floor.mse = sum / samples;
    return floor;
}

std::string paper_tables_markdown(const PaperTablesOptions& options, const PaperTablesLog& log) {
    Context cx{options, log, {}, {}};
    const double t_start = now_s();
    std::ostringstream md;
    const std::string dyn = "dyn";
    const std::vector<std::string> fdj_only = {kParamFdj};
    const std::vector<std::string> fdj_eta = {kParamFdj, kParamEtaO};

    md << "# The seed paper's tables, regenerated\n\n"
       << "Generated by `emadiag paper-tables" << (options.quick ? " --quick" : "") << " --seed " << options.seed
       << "` on freshly simulated data (EMA-REF-1, `ema-reference.md`). Every MSE is the normalised test MSE in the "
          "[0, 1] space of section 8 of `ema-reference.md`. The network is the paper's (section 2.8): T_R (eq. 7) "
          "resampled to N timesteps, tansig hidden layer, satlins output, SCG (MATLAB trainscg, sigma 5e-5, lambda "
          "5e-7), seeded 75/15/10 split, 12 validation failures, MSE goal 1e-6, 1000 epochs. The physics estimator "
          "(`estimate_physics`) is scored on the same test runs. Noise `typical` is the same runs with the section-6 "
          "noise added. Training time is wall time of SCG on this machine.\n\n";
    if (options.quick) md << "**Quick mode: counts, timesteps and neurons are cut down; the figures are not the paper's setting.**\n\n";

    // ---- Table 2 and 3: case A.
    const int a_runs = cx.runs(1000), a_steps = cx.steps(2000), a_neurons = cx.neurons(100);
    const Dataset& a_clean = cx.dataset(sim::LoadCase::A, sim::Sequence::Dyn, a_runs);
    const NetRow a_none = cx.train(a_clean, make_spec("A", dyn, a_steps, a_neurons, fdj_only), a_runs);
    const NetRow a_typ = cx.train(a_clean.with_noise(sim::NoiseProfile::Typical),
                                  make_spec("A", dyn, a_steps, a_neurons, fdj_only), a_runs);
    const ConfoundFloor floor = case_a_fdj_floor(kCaseAHingeNm, a_clean.constants.tau, options.quick ? 2000 : kFloorSamples,
                                                 options.seed);
    md << "## Table 2: case A (FDJ only; " << a_steps << " timesteps, " << a_runs << " runs, " << a_neurons
       << " neurons)\n\n";
    const double paper2[3] = {2.417e-4, 2.433e-4, 2.453e-4};
    performance_table(md, paper2, a_none, a_typ);
    confound_floor_paragraph(md, options, a_clean, a_none, floor);
    md << "## Table 3: case A, ten random test predictions (noise none)\n\n";
    ten_predictions(md, a_none,
                    {{{0.9782, 0.9792, 0.11}, {0.8399, 0.8442, 0.50}, {0.2670, 0.2722, 1.98}, {0.2687, 0.2614, 2.73},
                      {0.5300, 0.5160, 2.64}, {0.6933, 0.7047, 1.64}, {0.4183, 0.4505, 7.69}, {0.6042, 0.6013, 0.49},
                      {0.6015, 0.5843, 2.85}, {0.8478, 0.8707, 2.71}}},
                    options.seed);

    // ---- Table 4, 5, 6: case B.
    struct Setting {
        int timesteps, runs, neurons;
        double paper_train, paper_test;
    };
    const Setting settings[] = {{100, 100, 10, 6.007e-6, 1.611e-5},
                                {500, 100, 50, 4.364e-5, 4.244e-5},
                                {100, 500, 10, 6.217e-6, 6.730e-6},
                                {100, 500, 50, 4.529e-6, 7.643e-6},
                                {500, 500, 50, 1.742e-6, 2.601e-6}};
    const int b_max = cx.runs(500);
    const Dataset& b_clean = cx.dataset(sim::LoadCase::B, sim::Sequence::Dyn, b_max);
    const Dataset b_typ_data = b_clean.with_noise(sim::NoiseProfile::Typical);
    md << "## Table 4: case B settings (FDJ and eta_O)\n\n"
       << "| Timesteps | Runs | Neurons | Paper training | Paper test | Network training, none | Network test, none | Time, none "
          "| Network training, typical | Network test, typical | Time, typical | Physics test, none | Physics test, typical |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    std::optional<NetRow> b5_none, b5_typ;
    for (const Setting& s : settings) {
        const int runs = cx.runs(s.runs), steps = cx.steps(s.timesteps), neurons = cx.neurons(s.neurons);
        NetRow none = cx.train(b_clean, make_spec("B", dyn, steps, neurons, fdj_eta), runs);
        NetRow typ = cx.train(b_typ_data, make_spec("B", dyn, steps, neurons, fdj_eta), runs);
        md << "| " << steps << " | " << runs << " | " << neurons << " | " << sci(s.paper_train) << " | " << sci(s.paper_test)
           << " | " << sci(none.rep.mse.train) << " | " << sci(none.rep.mse.test) << " | " << secs(none.rep.train_time_s)
           << " | " << sci(typ.rep.mse.train) << " | " << sci(typ.rep.mse.test) << " | " << secs(typ.rep.train_time_s)
           << " | " << physics_cell(none.physics) << " | " << physics_cell(typ.physics) << " |\n";
        if (&s == &settings[4]) {
            b5_none = std::move(none);
            b5_typ = std::move(typ);
        }
    }
    md << '\n';
    md << "## Table 5: case B (" << cx.steps(500) << " timesteps, " << b_max << " runs, " << cx.neurons(50)
       << " neurons)\n\n";
    const double paper5[3] = {1.742e-6, 1.926e-6, 2.601e-6};
    performance_table(md, paper5, *b5_none, *b5_typ);

    // "Ours+": the same network fed speed and load too, trained past the paper's MSE goal.
    NetworkSpec plus = make_spec("B", dyn, cx.steps(500), cx.neurons(50), fdj_eta);
    plus.with_speed = true;
    plus.with_load = true;
    const NetRow plus_none = cx.train(b_clean, plus, b_max, kImprovedGoal);
    const NetRow plus_typ = cx.train(b_typ_data, plus, b_max, kImprovedGoal);
    md << "Network+ (the same network with speed and load F_R as extra inputs, MSE goal " << sci(kImprovedGoal)
       << ", still stopped by validation): test MSE " << sci(plus_none.rep.mse.test) << " (none, "
       << secs(plus_none.rep.train_time_s) << ", coverage " << pct(plus_none.rep.test_coverage95) << "), "
       << sci(plus_typ.rep.mse.test) << " (typical, " << secs(plus_typ.rep.train_time_s) << ", coverage "
       << pct(plus_typ.rep.test_coverage95) << ").\n\n";

    // "Network~": the paper's network on 25 window means of T_R (anti-aliased), 10 neurons: for noisy runs.
    NetworkSpec smooth = make_spec("B", dyn, cx.steps(25), cx.neurons(10), fdj_eta);
    smooth.resample = "mean";
    const NetRow smooth_none = cx.train(b_clean, smooth, b_max, kImprovedGoal);
    const NetRow smooth_typ = cx.train(b_typ_data, smooth, b_max, kImprovedGoal);
    md << "Network~ (T_R as " << smooth.timesteps << " window means instead of point interpolation, " << smooth.hidden_neurons
       << " neurons, MSE goal " << sci(kImprovedGoal) << "): test MSE " << sci(smooth_none.rep.mse.test) << " (none, "
       << secs(smooth_none.rep.train_time_s) << ", coverage " << pct(smooth_none.rep.test_coverage95) << "), "
       << sci(smooth_typ.rep.mse.test) << " (typical, " << secs(smooth_typ.rep.train_time_s) << ", coverage "
       << pct(smooth_typ.rep.test_coverage95) << ").\n\n";

    md << "## Table 6: case B, ten random test predictions (noise none)\n\n";
    ten_predictions(md, *b5_none,
                    {{{0.9648, 0.9596, 0.54}, {0.5432, 0.5415, 0.30}, {0.3115, 0.3107, 0.26}, {0.4217, 0.4195, 0.51},
                      {0.5003, 0.4987, 0.32}, {0.5839, 0.5842, 0.06}, {0.2609, 0.2608, 0.02}, {0.2121, 0.2123, 0.12},
                      {0.9311, 0.9312, 0.02}, {0.7147, 0.7158, 0.16}},
                     {{0.0761, 0.0756, 0.73}, {0.0734, 0.0730, 0.45}, {0.6876, 0.6871, 0.08}, {0.0984, 0.0979, 0.57},
                      {0.5235, 0.5224, 0.22}, {0.6001, 0.6012, 0.19}, {0.8887, 0.8914, 0.31}, {0.7008, 0.7015, 0.10},
                      {0.1336, 0.1349, 0.96}, {0.6471, 0.6499, 0.43}}},
                    options.seed + 6);

    // ---- Table 7: extended case A.
    const Dataset& ax_clean = cx.dataset(sim::LoadCase::AExt, sim::Sequence::Dyn, a_runs);
    const NetRow ax_none = cx.train(ax_clean, make_spec("A-ext", dyn, a_steps, a_neurons, fdj_eta), a_runs);
    const NetRow ax_typ = cx.train(ax_clean.with_noise(sim::NoiseProfile::Typical),
                                   make_spec("A-ext", dyn, a_steps, a_neurons, fdj_eta), a_runs);
    md << "## Table 7: extended case A (FDJ and eta_O; " << a_steps << " timesteps, " << a_runs << " runs, " << a_neurons
       << " neurons)\n\n";
    const double paper7[3] = {4.586e-4, 5.320e-4, 5.542e-4};
    performance_table(md, paper7, ax_none, ax_typ);

    // ---- Table 8: another command curve (sine sweep), case B.
    const Dataset& sw_clean = cx.dataset(sim::LoadCase::B, sim::Sequence::Sweep, b_max);
    const NetRow sw_none = cx.train(sw_clean, make_spec("B", "sweep", cx.steps(500), cx.neurons(50), fdj_eta), b_max);
    const NetRow sw_typ = cx.train(sw_clean.with_noise(sim::NoiseProfile::Typical),
                                   make_spec("B", "sweep", cx.steps(500), cx.neurons(50), fdj_eta), b_max);
    md << "## Table 8's idea: case B with another command curve (sequence `sweep`, a sine sweep; " << cx.steps(500)
       << " timesteps, " << b_max << " runs, " << cx.neurons(50) << " neurons)\n\n";
    const double paper8[3] = {3.349e-6, 3.296e-6, 2.344e-6};
    performance_table(md, paper8, sw_none, sw_typ);

    const TableRows rows{a_none, a_typ, b5_none, b5_typ, plus_none, plus_typ, smooth_none, smooth_typ, ax_none, ax_typ, sw_none, sw_typ};
    goals_section(md, rows, floor);
    calibration_section(md, cx, rows);
    if (!b5_none->physics.first_failure.empty() || !a_none.physics.first_failure.empty()) {
        md << "Physics estimator failures (first message): " << b5_none->physics.first_failure << " "
           << a_none.physics.first_failure << "\n\n";
    }
    md << "Total wall time: " << secs(now_s() - t_start) << ".\n";
    return md.str();
}

}  // namespace emadiag
