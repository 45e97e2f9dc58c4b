#include "diagnosis/verdict.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/health_estimate.hpp"
#include "estimation/run_checks.hpp"

#include <sstream>
#include <utility>

namespace emadiag {

AssessedRun assess_run(const Run& run, sim::Sequence sequence, bool valid, std::string invalid_reason) {
    AssessedRun a;
    a.sequence = sequence;
    a.valid = valid;
    a.invalid_reason = std::move(invalid_reason);
    if (!a.valid) return a;
    try {
        a.estimates = estimate_run(check_run(run));  // the run enters the analysis here
    } catch (const EmadiagError& e) {
        a.valid = false;
        a.invalid_reason = std::string("not estimated: ") + e.what();
    }
    return a;
}
namespace {

std::string describe(const Finding& f) {
    std::ostringstream os;
    os.precision(4);
    os << f.parameter << ' ' << *f.value << " (95 % [" << *f.value - kZ95 * *f.std_error << ", " << *f.value + kZ95 * *f.std_error
       << "]) against its " << to_string(f.limit->kind) << ' ' << f.limit->limit << " (" << to_string(f.estimator) << ')';
    return os.str();
}

bool is_physics(const Finding& f) { return f.estimator.method == EstimatorMethod::Physics; }

}  // namespace

const char* to_string(FindingStatus s) {
    switch (s) {
        case FindingStatus::Within: return "WITHIN";
        case FindingStatus::Beyond: return "BEYOND";
        case FindingStatus::Straddles: return "STRADDLES";
        case FindingStatus::NotIdentifiable: return "NOT_IDENTIFIABLE";
        case FindingStatus::NotEstimated: return "NOT_ESTIMATED";
    }
    return "?";
}

const char* to_string(Verdict v) {
    switch (v) {
        case Verdict::Serviceable: return "SERVICEABLE";
        case Verdict::Unserviceable: return "UNSERVICEABLE";
        case Verdict::Inconclusive: return "INCONCLUSIVE";
        case Verdict::NoTest: return "NO_TEST";
    }
    return "?";
}

FindingStatus classify(double value, double std_error, const ParameterLimit& limit) {
    const double lo = value - kZ95 * std_error;
    const double hi = value + kZ95 * std_error;
    if (limit.kind == LimitKind::Max) {
        if (hi <= limit.limit) return FindingStatus::Within;
        return lo > limit.limit ? FindingStatus::Beyond : FindingStatus::Straddles;
    }
    if (lo >= limit.limit) return FindingStatus::Within;
    return hi < limit.limit ? FindingStatus::Beyond : FindingStatus::Straddles;
}

Assessment assess(const std::vector<AssessedRun>& runs, const HealthLimits& limits) {
    Assessment a;
    for (const auto& r : runs) {
        if (!r.estimates) continue;
        for (const auto& h : r.estimates->estimates) {
            for (const auto& p : h.parameters) {
                Finding f;
                f.parameter = p.name;
                f.estimator = EstimatorId{h.estimator, r.sequence};
                f.note = p.note;
                if (const auto* l = limits.find(p.name)) f.limit = *l;
                if (!p.value) {
                    f.status = p.identifiable ? FindingStatus::NotEstimated : FindingStatus::NotIdentifiable;
                } else {
                    f.value = p.value;
                    f.std_error = p.std_error;
                    f.status = f.limit ? classify(*p.value, p.std_error, *f.limit) : FindingStatus::NotEstimated;
                }
                a.findings.push_back(std::move(f));
            }
        }
    }
    if (runs.empty()) {
        a.verdict = Verdict::NoTest;
        a.reason = "no test sequence was run";
        return a;
    }
    for (const auto& r : runs) {
        if (!r.valid) {
            a.verdict = Verdict::NoTest;
            a.reason = "the " + sim::to_string(r.sequence) + " run is not valid (" + r.invalid_reason + "); nothing is concluded, repeat the test";
            return a;
        }
    }
    auto first = [&](auto pred) -> const Finding* {
        for (const auto& f : a.findings)
            if (pred(f)) return &f;
        return nullptr;
    };
    if (const Finding* f = first([](const Finding& x) { return is_physics(x) && x.status == FindingStatus::Beyond; })) {
        a.verdict = Verdict::Unserviceable;
        a.reason = describe(*f) + " is beyond the limit";
        return a;
    }
    if (const Finding* f = first([](const Finding& x) { return is_physics(x) && x.status == FindingStatus::Straddles; })) {
        a.verdict = Verdict::Inconclusive;
        a.reason = describe(*f) + " straddles the limit; repeat the test";
        return a;
    }
    if (const Finding* f = first([](const Finding& x) { return !is_physics(x) && x.status == FindingStatus::Beyond; })) {
        a.verdict = Verdict::Inconclusive;
        a.reason = "the methods disagree: " + describe(*f) + " is beyond the limit while the physics estimator finds it within";
        return a;
    }
    if (!first([](const Finding& x) { return is_physics(x) && x.status == FindingStatus::Within; })) {
        a.verdict = Verdict::Inconclusive;
        a.reason = "no parameter could be measured against a limit";
        return a;
    }
    a.verdict = Verdict::Serviceable;
    a.reason = "every measured parameter is within its limit with 95 % confidence";
    return a;
}

}  // namespace emadiag
