#pragma once
// `emadiag paper-tables`: the seed paper's Tables 2 to 8 regenerated on freshly simulated data,
// the paper's figure beside ours, for the network (section 2.8) and the physics estimator, with
// noise none (as in the paper) and typical, and the training time beside each row. All MSE figures
// are in the normalised [0, 1] space of ema-reference.md section 8.
#include <cstdint>
#include <functional>
#include <string>

namespace emadiag {

struct PaperTablesOptions {
    bool quick = false;         ///< small counts so a test exercises every table in seconds
    std::uint64_t seed = 2026;  ///< seeds every dataset, split and initialisation
    unsigned threads = 2;
    bool physics = true;        ///< also run the physics estimator on the test runs
};

/// Progress lines for the caller to print (libraries never print).
using PaperTablesLog = std::function<void(const std::string& line)>;

/// The whole Markdown document.
[[nodiscard]] std::string paper_tables_markdown(const PaperTablesOptions& options, const PaperTablesLog& log = {});

/// The floor the eta confound sets on FDJ in case A: with a constant load F_R = H / tau the
/// residual torque only shows s = FDJ + c(eta) |F_R| (eq. (5); c = 1/eta_O - 1 opposing, which eq. (4)
/// makes equal to 1 - eta_A aiding to within c_difference_max), so the best possible predictor of
/// FDJ is E[FDJ | s]. Returns its normalised MSE (Monte Carlo over `samples` draws of section 8,
/// posterior on a grid of eta_A), seeded.
struct ConfoundFloor {
    double mse = 0;                 ///< normalised MSE of E[FDJ | s]
    double c_difference_max = 0;    ///< max over eta of |(1/eta_O - 1) - (1 - eta_A)| |F_R|, N m
};
[[nodiscard]] ConfoundFloor case_a_fdj_floor(double hinge_moment_nm, double tau, int samples, std::uint64_t seed);

}  // namespace emadiag
