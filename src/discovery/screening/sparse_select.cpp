#include "discovery/screening/sparse_select.hpp"

#include "discovery/screening/screen_windows.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace emadiag::discovery {
namespace {

/// Residual of y after least squares on x (columns), over the given rows.
Eigen::VectorXd residual_after(const Eigen::MatrixXd& x, const Eigen::VectorXd& y) {
    if (x.cols() == 0) return y;
    const Eigen::VectorXd b = x.colPivHouseholderQr().solve(y);
    return y - x * b;
}

Eigen::MatrixXd rows_of(const Eigen::MatrixXd& m, const std::vector<Eigen::Index>& idx) {
    Eigen::MatrixXd out(static_cast<Eigen::Index>(idx.size()), m.cols());
    for (std::size_t i = 0; i < idx.size(); ++i) out.row(static_cast<Eigen::Index>(i)) = m.row(idx[i]);
    return out;
}
Eigen::VectorXd rows_of(const Eigen::VectorXd& v, const std::vector<Eigen::Index>& idx) {
    Eigen::VectorXd out(static_cast<Eigen::Index>(idx.size()));
    for (std::size_t i = 0; i < idx.size(); ++i) out(static_cast<Eigen::Index>(i)) = v(idx[i]);
    return out;
}

/// One family screened: its best shape (largest drop of the RSS after the base columns) with its
/// coefficients, standard errors, delta BIC and peak torque in `best`, and that shape's window columns
/// in `best_cols` (for the checks of screen_generated). False when no shape lies outside the base
/// columns' span with a gain.
bool screen_family(const RunSignals& s, const WindowedBase& wb, const TermFamily& fam, Eigen::Index p, double log_g,
                   GenericEvidence& best, Eigen::MatrixXd& best_cols) {
    const std::vector<std::size_t>& rows = wb.rows;
    const auto ni = static_cast<Eigen::Index>(wb.windows.size());
    const double weight_sum = wb.weight_sum;
    const Eigen::VectorXd& e0 = wb.e0;
    const double rss0 = wb.rss0;
    const double dn = static_cast<double>(ni);
    best.family = fam.name;
    double best_drss = -1;
    Eigen::VectorXd best_b;
    Eigen::MatrixXd best_xr;
    std::vector<std::vector<double>> best_full;
    for (const auto& shape : fam.shapes) {
        const auto k = static_cast<Eigen::Index>(shape.size());
        Eigen::MatrixXd x(ni, k);
        std::vector<std::vector<double>> full;
        for (Eigen::Index j = 0; j < k; ++j) {
            full.push_back(term_signature(s, shape[static_cast<std::size_t>(j)]));
            x.col(j) = wb.window_sums(full.back());
        }
        const double raw = x.squaredNorm();
        Eigen::MatrixXd xr = wb.project_out(x);
        if (!(xr.squaredNorm() > kMinResidualColumnFraction * raw) || raw == 0) continue;
        const Eigen::MatrixXd xtx = xr.transpose() * xr;
        const Eigen::VectorXd b = xtx.ldlt().solve(xr.transpose() * e0);
        const double drss = b.dot(xr.transpose() * e0);
        if (!(drss > best_drss)) continue;
        best_drss = drss;
        best_b = b;
        best_xr = xr;
        best_full = full;
        best.terms = shape;
        best_cols = x;
    }
    if (best_drss < 0) return false;
    const auto k = static_cast<double>(best.terms.size());
    const double rss1 = std::max(rss0 - best_drss, std::numeric_limits<double>::min());
    best.rss_ratio = rss1 / rss0;
    best.delta_bic = dn * std::log(rss0 / rss1) - (k + fam.scanned) * std::log(dn) - 2.0 * log_g;
    best.explained_rms_nm = std::sqrt(best_drss / weight_sum);
    const Eigen::MatrixXd cov = (rss1 / std::max(1.0, dn - static_cast<double>(p) - k)) *
                                (best_xr.transpose() * best_xr).inverse();
    for (std::size_t j = 0; j < best.terms.size(); ++j) {
        best.terms[j].coefficient = best_b(static_cast<Eigen::Index>(j));
        best.se.push_back(std::sqrt(std::max(0.0, cov(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(j)))));
    }
    for (std::size_t kk : rows) {
        double v = 0;
        for (std::size_t j = 0; j < best_full.size(); ++j) v += best_b(static_cast<Eigen::Index>(j)) * best_full[j][kk];
        best.peak_torque_nm = std::max(best.peak_torque_nm, std::abs(v));
    }
    return true;
}

/// Sorts out.ranking by delta BIC, best first; returns the family index (in `lib`) of each entry.
std::vector<std::size_t> sort_by_delta_bic(GenericScreen& out, const std::vector<TermFamily>& lib) {
    // Keep the family index with its evidence while sorting.
    std::vector<std::size_t> order(out.ranking.size());
    std::vector<std::size_t> fam_of(out.ranking.size());
    {
        std::size_t r = 0;
        for (std::size_t f = 0; f < lib.size() && r < out.ranking.size(); ++f) {
            if (out.ranking[r].family == lib[f].name) fam_of[r++] = f;
        }
    }
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(),
              [&](std::size_t a, std::size_t b) { return out.ranking[a].delta_bic > out.ranking[b].delta_bic; });
    std::vector<GenericEvidence> sorted;
    std::vector<std::size_t> sorted_fam;
    for (std::size_t i : order) {
        sorted.push_back(out.ranking[i]);
        sorted_fam.push_back(fam_of[i]);
    }
    out.ranking = std::move(sorted);
    return sorted_fam;
}

/// Equivalent families: each one's fitted contribution (its best shape's columns with the model's
/// columns projected out) reproduces the other's to R^2 >= kEquivalentR2 over the windows (e.g.
/// sgn(w) F_R^2 and sgn(w) |theta_u| F_R^2 under a load that grows with the deflection).
class FamilyEquivalence {
public:
    FamilyEquivalence(const WindowedBase& wb, const std::vector<Eigen::MatrixXd>& best_cols,
                      const std::vector<std::size_t>& sorted_fam)
        : proj_(best_cols.size()), fitted_(best_cols.size()) {
        for (std::size_t f : sorted_fam) {
            if (best_cols[f].cols() == 0) continue;
            proj_[f] = wb.project_out(best_cols[f]);
            fitted_[f] = proj_[f] * proj_[f].colPivHouseholderQr().solve(wb.e0);
        }
    }
    [[nodiscard]] bool equivalent(std::size_t a, std::size_t b) const { return a == b || (reproduces(a, b) && reproduces(b, a)); }

private:
    [[nodiscard]] bool reproduces(std::size_t a, std::size_t b) const {  // a's columns reproduce b's fitted contribution
        const double ss = fitted_[b].squaredNorm();
        if (proj_[a].cols() == 0 || !(ss > 0)) return false;
        return 1.0 - residual_after(proj_[a], fitted_[b]).squaredNorm() / ss >= kEquivalentR2;
    }
    std::vector<Eigen::MatrixXd> proj_;
    std::vector<Eigen::VectorXd> fitted_;
};

/// Parsimony: among the families equivalent to the best whose delta BIC is within kParsimonyBic of
/// it (no evidence between them), the one with the fewest factors leads.
void lead_by_parsimony(GenericScreen& out, std::vector<std::size_t>& sorted_fam, const FamilyEquivalence& eq) {
    auto degree = [&](std::size_t i) { return term_degree(out.ranking[i].terms); };
    std::size_t lead = 0;
    for (std::size_t i = 1; i < out.ranking.size(); ++i) {
        if (out.ranking[i].delta_bic < out.ranking.front().delta_bic - kParsimonyBic) break;
        if (degree(i) < degree(lead) && eq.equivalent(sorted_fam[i], sorted_fam.front())) lead = i;
    }
    if (lead != 0) {
        std::rotate(out.ranking.begin(), out.ranking.begin() + static_cast<std::ptrdiff_t>(lead),
                    out.ranking.begin() + static_cast<std::ptrdiff_t>(lead) + 1);
        std::rotate(sorted_fam.begin(), sorted_fam.begin() + static_cast<std::ptrdiff_t>(lead),
                    sorted_fam.begin() + static_cast<std::ptrdiff_t>(lead) + 1);
    }
}

/// Block-time cross-validation: contiguous folds of windows; 1 - the held-out error with the top
/// family's columns / without.
double block_cv_gain(const WindowedBase& wb, const Eigen::MatrixXd& top_cols) {
    const auto ni = static_cast<Eigen::Index>(wb.windows.size());
    const Eigen::MatrixXd& x0 = wb.x0;
    const Eigen::VectorXd& y = wb.y;
    double cv0 = 0, cv1 = 0;
    Eigen::MatrixXd x1(ni, x0.cols() + top_cols.cols());
    x1 << x0, top_cols;
    for (int fold = 0; fold < kCvFolds; ++fold) {
        std::vector<Eigen::Index> train, test;
        for (Eigen::Index i = 0; i < ni; ++i) {
            const auto f = static_cast<int>(i * kCvFolds / ni);
            (f == fold ? test : train).push_back(i);
        }
        if (test.empty() || train.size() < static_cast<std::size_t>(x1.cols()) + 2) continue;
        const Eigen::VectorXd ytr = rows_of(y, train);
        const Eigen::VectorXd b0 = rows_of(x0, train).colPivHouseholderQr().solve(ytr);
        const Eigen::VectorXd b1 = rows_of(x1, train).colPivHouseholderQr().solve(ytr);
        const Eigen::VectorXd yte = rows_of(y, test);
        cv0 += (yte - rows_of(x0, test) * b0).squaredNorm();
        cv1 += (yte - rows_of(x1, test) * b1).squaredNorm();
    }
    return cv0 > 0 ? 1.0 - cv1 / cv0 : 0.0;
}

/// The screened families' best shapes: window columns and term counts, by family index in the library.
struct FamilyColumns {
    std::vector<Eigen::MatrixXd> cols;
    std::vector<int> k;
};

/// Stability: moving-block bootstrap of the windows; the family with the largest penalised gain wins.
/// Returns the fraction of kStabilityResamples resamples the top family holds in.
double bootstrap_stability(const WindowedBase& wb, const FamilyColumns& best, const std::vector<TermFamily>& lib,
                           const std::vector<std::size_t>& sorted_fam, const FamilyEquivalence& eq, double log_g,
                           std::uint64_t seed) {
    const std::vector<std::vector<std::size_t>>& windows = wb.windows;
    const Eigen::MatrixXd& x0 = wb.x0;
    const Eigen::VectorXd& y = wb.y;
    const std::vector<Eigen::MatrixXd>& best_cols = best.cols;
    const std::vector<int>& best_k = best.k;
    const std::size_t top_fam = sorted_fam.front();
    std::vector<signed char> equivalent_to_top_memo(lib.size(), -1);  // the resamples below ask again and again
    auto equivalent_to_top = [&](std::size_t f) {
        if (equivalent_to_top_memo[f] < 0) equivalent_to_top_memo[f] = eq.equivalent(f, top_fam) ? 1 : 0;
        return equivalent_to_top_memo[f] == 1;
    };
    std::mt19937_64 rng(seed);
    int wins = 0;
    const std::size_t blocks = std::max<std::size_t>(1, windows.size() / kStabilityBlockWindows);
    for (int r = 0; r < kStabilityResamples; ++r) {
        std::vector<Eigen::Index> idx;
        for (std::size_t b = 0; b < blocks; ++b) {
            const std::size_t start = rng() % std::max<std::size_t>(1, windows.size() - kStabilityBlockWindows + 1);
            for (std::size_t i = 0; i < kStabilityBlockWindows && start + i < windows.size(); ++i) {
                idx.push_back(static_cast<Eigen::Index>(start + i));
            }
        }
        const Eigen::MatrixXd xb = rows_of(x0, idx);
        const Eigen::VectorXd eb = residual_after(xb, rows_of(y, idx));
        const double rb0 = eb.squaredNorm();
        const double nb = static_cast<double>(idx.size());
        double best_score = -std::numeric_limits<double>::infinity();
        double top_score = -std::numeric_limits<double>::infinity();
        std::size_t best_f = top_fam;
        for (std::size_t i = 0; i < sorted_fam.size(); ++i) {
            const std::size_t f = sorted_fam[i];
            if (best_cols[f].cols() == 0) continue;
            Eigen::MatrixXd xr = rows_of(best_cols[f], idx);
            for (Eigen::Index j = 0; j < xr.cols(); ++j) xr.col(j) = residual_after(xb, Eigen::VectorXd(xr.col(j)));
            const Eigen::VectorXd e1 = residual_after(xr, eb);
            const double rb1 = std::max(e1.squaredNorm(), std::numeric_limits<double>::min());
            const double score = nb * std::log(rb0 / rb1) - (best_k[f] + lib[f].scanned) * std::log(nb);
            if (score > best_score) {
                best_score = score;
                best_f = f;
            }
            if (f == top_fam) top_score = score;
        }
        // The family holds in this resample when it still passes the BIC with the Bonferroni
        // allowance and no other family beats it by more than kStabilityTie, or the one that does
        // is equivalent to it (near-equivalent families, e.g. sgn(w) w^2 and sgn(w) w^2 |F_R|,
        // share the wins otherwise).
        wins += top_score - 2.0 * log_g > 0 && (top_score >= best_score - kStabilityTie || equivalent_to_top(best_f)) ? 1 : 0;
    }
    return static_cast<double>(wins) / kStabilityResamples;
}

/// Each entry's reason, and accepted for the one that passes every check.
void give_reasons(std::vector<GenericEvidence>& ranking) {
    for (auto& e : ranking) {
        if (e.delta_bic <= 0) {
            e.reason = "delta BIC " + fmt3(e.delta_bic) + " <= 0";
        } else if (e.peak_torque_nm < kMinEffectPeakNm) {
            e.reason = "peak torque " + fmt3(e.peak_torque_nm) + " N m < " + fmt3(kMinEffectPeakNm) + " N m";
        } else if (!e.checked) {
            e.reason = "passes delta BIC; the best family is added first";
        } else if (e.cv_gain <= 0) {
            e.reason = "block cross-validation: no gain on held-out time (" + fmt3(e.cv_gain) + ")";
        } else if (e.stability < kMinStability) {
            e.reason = "unstable: wins in " + fmt3(100 * e.stability) + " % of resamples";
        } else {
            e.accepted = true;
            e.reason = "delta BIC " + fmt3(e.delta_bic) + ", CV gain " + fmt3(e.cv_gain) + ", stability " +
                       fmt3(e.stability) + ", peak " + fmt3(e.peak_torque_nm) + " N m";
        }
    }
}

}  // namespace

GenericScreen screen_generated(const RunSignals& s, const ScreenInput& in, const std::vector<TermFamily>& lib,
                               std::uint64_t seed) {
    const WindowedBase wb = windowed_base(s, in);
    const auto p = static_cast<Eigen::Index>(in.base_columns.size());

    GenericScreen out;
    out.shapes = library_size(lib);
    const double log_g = std::log(static_cast<double>(std::max<std::size_t>(1, out.shapes)));
    // Per family: the best shape's window columns (for the checks below).
    FamilyColumns best{std::vector<Eigen::MatrixXd>(lib.size()), std::vector<int>(lib.size(), 0)};
    for (std::size_t f = 0; f < lib.size(); ++f) {
        GenericEvidence e;
        if (!screen_family(s, wb, lib[f], p, log_g, e, best.cols[f])) continue;
        best.k[f] = static_cast<int>(e.terms.size());
        out.ranking.push_back(e);
    }
    std::vector<std::size_t> sorted_fam = sort_by_delta_bic(out, lib);
    if (out.ranking.empty()) return out;

    const FamilyEquivalence eq(wb, best.cols, sorted_fam);
    lead_by_parsimony(out, sorted_fam, eq);

    GenericEvidence& top = out.ranking.front();
    top.cv_gain = block_cv_gain(wb, best.cols[sorted_fam.front()]);
    top.stability = bootstrap_stability(wb, best, lib, sorted_fam, eq, log_g, seed);
    top.checked = true;
    give_reasons(out.ranking);
    return out;
}

std::size_t term_degree(const std::vector<sim::Term>& terms) {
    std::size_t d = 0;
    for (const auto& t : terms) d = std::max(d, t.factors.size());
    return d;
}

bool is_period_basis(const sim::TermFactor& f) { return f.basis == sim::TermBasis::Sin || f.basis == sim::TermBasis::Cos; }

const sim::TermFactor* period_factor(const sim::Term& t) {
    for (const auto& f : t.factors) {
        if (is_period_basis(f)) return &f;
    }
    return nullptr;
}

std::vector<sim::Term> refine_period(const RunSignals& s, const ScreenInput& in, const GenericEvidence& best,
                                     std::uint64_t seed) {
    if (best.terms.empty() || period_factor(best.terms.front()) == nullptr) return best.terms;
    // Twice: over kPeriodRefineSpan, then over one step of that grid around its best (a period 0.8 %
    // off, half a step of the first grid, leaves a phase error that grows over the travel and reads as
    // a position sensor drift: seed 113's periodic surface torque of period 5 deg found at 4.961).
    GenericEvidence current = best;
    double span = kPeriodRefineSpan;
    for (int pass = 0; pass < 2; ++pass) {
        const double p0 = period_factor(current.terms.front())->a;
        TermFamily fam{current.family, {}, 1};
        for (int i = 0; i < kPeriodRefinePoints; ++i) {
            const double x = -1.0 + 2.0 * i / (kPeriodRefinePoints - 1);
            const double period = p0 * std::pow(span, x);
            std::vector<sim::Term> block = current.terms;
            for (auto& t : block) {
                t.coefficient = 1.0;
                for (auto& f : t.factors) {
                    if (is_period_basis(f)) f.a = period;
                }
            }
            fam.shapes.push_back(std::move(block));
        }
        const GenericScreen fine = screen_generated(s, in, {fam}, seed);
        if (!fine.ranking.empty() && fine.ranking.front().delta_bic > current.delta_bic) current = fine.ranking.front();
        span = std::pow(span, 2.0 / (kPeriodRefinePoints - 1));
    }
    return current.terms;
}

}  // namespace emadiag::discovery
