#include "estimation/dataset.hpp"

#include "core/emadiag_error.hpp"
#include "estimation/health_estimate.hpp"
#include "emadiag/io/bounded_json.hpp"
#include "emadiag/io/output_path.hpp"
#include "emadiag/sim/physics.hpp"
#include "emadiag/sim/sim_error.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <random>

namespace emadiag {
namespace {

static_assert(std::endian::native == std::endian::little, "the dataset format is little-endian");

constexpr char kMagic[8] = {'E', 'M', 'A', 'D', 'S', 'E', 'T', '1'};
constexpr int kFormatVersion = 1;
constexpr int kColumns = 6;
constexpr int kLabelCount = 4;
constexpr const char* kColumnNames[kColumns] = {"t_s", "current_A", "speed_rad_s", "theta_m_rad", "hinge_moment_Nm", "command_deg"};
constexpr const char* kLabelNames[kLabelCount] = {kParamFdj, kParamFsj, kParamEtaO, kParamEtaA};
// The datasheet's nominal values and the section-8 spread (+/-20 %), from emadiag/sim/physics.hpp.
constexpr double kNominalFdjNm = sim::ema_ref_1::kFdjNm;
constexpr double kNominalFsjNm = sim::ema_ref_1::kFsjNm;
constexpr double kNominalEtaA = sim::ema_ref_1::kEtaA;
using sim::kHealthSpread;
constexpr double kDatasheetTau = sim::ema_ref_1::kTau;
constexpr int kGroupsPerThread = 2;  // batch groups per thread and chunk


}  // namespace

namespace {

HealthParameter health_parameter_named(const std::string& param) {
    if (const auto p = parse_health_parameter(param)) return *p;
    throw EmadiagError("unknown health parameter '" + param + "' (expected FDJ_Nm, FSJ_Nm, eta_O or eta_A)");
}

}  // namespace

HealthRange health_range(const std::string& param) { return health_range(health_parameter_named(param)); }

HealthRange health_range(HealthParameter param) {
    const auto around = [](double nominal) {
        return HealthRange{nominal * (1.0 - kHealthSpread), nominal * (1.0 + kHealthSpread)};
    };
    switch (param) {
        case HealthParameter::Fdj: return around(kNominalFdjNm);
        case HealthParameter::Fsj: return around(kNominalFsjNm);
        case HealthParameter::EtaA: return around(kNominalEtaA);
        case HealthParameter::EtaO: {
            const HealthRange a = around(kNominalEtaA);
            return HealthRange{sim::eta_o_from_eta_a(a.lo, kDatasheetTau), sim::eta_o_from_eta_a(a.hi, kDatasheetTau)};
        }
    }
    throw EmadiagError("unknown health parameter");
}

double HealthLabels::get(const std::string& param) const { return get(health_parameter_named(param)); }

double HealthLabels::get(HealthParameter param) const {
    switch (param) {
        case HealthParameter::Fdj: return fdj_nm;
        case HealthParameter::Fsj: return fsj_nm;
        case HealthParameter::EtaO: return eta_o;
        case HealthParameter::EtaA: return eta_a;
    }
    throw EmadiagError("unknown health parameter");
}

void HealthLabels::apply_to(sim::EmaParams& params) const {
    params.fdj_nm = fdj_nm;
    params.fsj_nm = fsj_nm;
    params.eta_o = eta_o;
    params.eta_a = eta_a;
}

double uniform01(std::uint64_t draw) { return static_cast<double>(draw >> 11) * 0x1.0p-53; }

std::string classify_simulation(const sim::SimResult& result, const sim::EmaParams& params) {
    if (!result.finite) return "non_finite";
    for (const auto& s : result.samples) {
        if (!std::isfinite(s.t_s) || !std::isfinite(s.current_a) || !std::isfinite(s.speed_rad_s) ||
            !std::isfinite(s.theta_m_rad) || !std::isfinite(s.hinge_moment_nm)) {
            return "non_finite";
        }
    }
    constexpr double kRadToDeg = 57.29577951308232;
    for (const auto& s : result.samples) {
        if (std::abs(s.current_a) > params.i_max_a + kFilterCurrentMarginA ||
            std::abs(s.speed_rad_s) > params.v_dc_v / params.k_t_nm_per_a ||
            std::abs(s.theta_m_rad / params.tau * kRadToDeg) > params.stop_deg + kFilterAngleMarginDeg) {
            return "non_physical";
        }
    }
    // A numerical limit cycle shows as the speed reversing again and again at large amplitude.
    int reversals = 0;
    int last_sign = 0;
    for (const auto& s : result.samples) {
        if (std::abs(s.speed_rad_s) < kLimitCycleSpeedRadS) continue;
        const int sign = s.speed_rad_s > 0 ? 1 : -1;
        if (last_sign != 0 && sign != last_sign) ++reversals;
        last_sign = sign;
    }
    if (reversals > kLimitCycleMaxReversals) return "limit_cycle";
    return "";
}

Run Dataset::run(std::size_t i) const {
    if (i >= runs.size()) {
        throw EmadiagError("dataset run index " + std::to_string(i) + " out of range (" + std::to_string(runs.size()) +
                           " runs)");
    }
    Run r;
    r.constants = constants;
    r.load_case = spec.load_case;
    r.sequence = spec.sequence;
    r.set_meta("source", "emadiag dataset");
    r.set_required_meta();
    r.set_meta("noise", sim::to_string(spec.noise));
    r.set_meta("seed", std::to_string(runs[i].noise_seed));
    r.samples = runs[i].samples;
    return r;
}

Dataset Dataset::with_noise(sim::NoiseProfile noise) const {
    if (spec.noise != sim::NoiseProfile::None) {
        throw EmadiagError("with_noise needs a noiseless dataset, this one has noise " + sim::to_string(spec.noise));
    }
    Dataset d = *this;
    d.spec.noise = noise;
    for (auto& r : d.runs) sim::apply_noise(r.samples, noise, r.noise_seed);
    return d;
}

Dataset generate_dataset(const DatasetSpec& spec, unsigned threads, const DatasetProgress& progress) {
    if (spec.count < 1 || spec.count > kMaxDatasetCount) {
        throw EmadiagError("dataset count " + std::to_string(spec.count) + " is outside [1, " + std::to_string(kMaxDatasetCount) +
                           "] (kMaxDatasetCount)");
    }
    threads = std::max(1u, threads);
    const sim::EmaParams datasheet = sim::EmaParams::datasheet();
    Dataset d;
    d.spec = spec;
    d.constants = RunConstants{datasheet.k_t_nm_per_a, datasheet.j_kgm2, datasheet.tau, sim::kSamplePeriodS};
    std::mt19937_64 rng(spec.seed);
    const int max_simulations = kMaxSimulationsPerRun * spec.count;
    // A chunk is whole batch groups of the instruction set in use (lanes x groups simulations each),
    // so no lane is padding; the runs drawn do not depend on it (each chunk stops at spec.count).
    const sim::SimdTarget simd = sim::simd_target();
    const int chunk = kGroupsPerThread * simd.lanes * simd.groups * static_cast<int>(threads);
    while (d.filter.accepted < spec.count && d.filter.simulated < max_simulations) {
        const int n = std::min({chunk, max_simulations - d.filter.simulated, spec.count - d.filter.accepted});
        std::vector<sim::SimConfig> configs(static_cast<std::size_t>(n));
        std::vector<HealthLabels> labels(configs.size());
        std::vector<std::uint64_t> noise_seeds(configs.size());
        for (std::size_t k = 0; k < configs.size(); ++k) {
            labels[k] = draw_health_labels(rng, datasheet.tau);
            noise_seeds[k] = rng();
            sim::SimConfig& c = configs[k];
            c.params = datasheet;
            labels[k].apply_to(c.params);
            c.load_case = spec.load_case;
            c.sequence = spec.sequence;
            c.noise = sim::NoiseProfile::None;  // noise is applied after the filter, per run
            c.seed = noise_seeds[k];
        }
        std::vector<sim::SimResult> results = sim::simulate_batch(configs, threads);
        for (std::size_t k = 0; k < results.size(); ++k) {
            ++d.filter.simulated;
            const std::string verdict = classify_simulation(results[k], configs[k].params);
            if (verdict == "non_finite") {
                ++d.filter.non_finite;
            } else if (verdict == "limit_cycle") {
                ++d.filter.limit_cycle;
            } else if (verdict == "non_physical") {
                ++d.filter.non_physical;
            } else {
                ++d.filter.accepted;
                DatasetRun run{labels[k], noise_seeds[k], std::move(results[k].samples)};
                sim::apply_noise(run.samples, spec.noise, run.noise_seed);
                d.runs.push_back(std::move(run));
            }
        }
        if (progress) progress(d.filter.simulated, d.filter.accepted, spec.count);
    }
    if (d.filter.accepted < spec.count) {
        throw EmadiagError("only " + std::to_string(d.filter.accepted) + " of " + std::to_string(d.filter.simulated) +
                           " simulations passed the filter (non-finite " + std::to_string(d.filter.non_finite) +
                           ", limit cycle " + std::to_string(d.filter.limit_cycle) + ", non-physical " +
                           std::to_string(d.filter.non_physical) + "), wanted " + std::to_string(spec.count));
    }
    return d;
}

void write_dataset(const std::string& path, const Dataset& dataset) {
    io::OutputFile<EmadiagError> file(path, "dataset");  // whole or not at all (emadiag/io/output_path.hpp)
    std::ostream& out = file.stream();
    const std::size_t samples_per_run = dataset.runs.empty() ? 0 : dataset.runs.front().samples.size();
    for (std::size_t i = 0; i < dataset.runs.size(); ++i) {
        if (dataset.runs[i].samples.size() != samples_per_run) {
            throw EmadiagError(path + ": run " + std::to_string(i) + " has " +
                               std::to_string(dataset.runs[i].samples.size()) + " samples, run 0 has " +
                               std::to_string(samples_per_run));
        }
    }
    const nlohmann::json header = {
        {"format", "emadiag-dataset"},
        {"version", kFormatVersion},
        {"case", sim::to_string(dataset.spec.load_case)},
        {"sequence", sim::to_string(dataset.spec.sequence)},
        {"noise", sim::to_string(dataset.spec.noise)},
        {"seed", dataset.spec.seed},
        {"count", dataset.spec.count},
        {"runs", dataset.runs.size()},
        {"samples_per_run", samples_per_run},
        {"columns", kColumnNames},
        {"labels", kLabelNames},
        {"constants",
         {{"k_t_Nm_per_A", dataset.constants.k_t_nm_per_a},
          {"J_kgm2", dataset.constants.j_kgm2},
          {"tau", dataset.constants.tau},
          {"sample_period_s", dataset.constants.sample_period_s}}},
        {"filter",
         {{"simulated", dataset.filter.simulated},
          {"accepted", dataset.filter.accepted},
          {"non_finite", dataset.filter.non_finite},
          {"limit_cycle", dataset.filter.limit_cycle},
          {"non_physical", dataset.filter.non_physical}}},
    };
    const std::string text = header.dump();
    const std::uint64_t length = text.size();
    out.write(kMagic, sizeof kMagic);
    out.write(reinterpret_cast<const char*>(&length), sizeof length);
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
    std::vector<double> row(kColumns * samples_per_run);
    for (const auto& r : dataset.runs) {
        const double labels[kLabelCount] = {r.labels.fdj_nm, r.labels.fsj_nm, r.labels.eta_o, r.labels.eta_a};
        out.write(reinterpret_cast<const char*>(labels), sizeof labels);
        out.write(reinterpret_cast<const char*>(&r.noise_seed), sizeof r.noise_seed);
        for (std::size_t k = 0; k < samples_per_run; ++k) {
            const auto& s = r.samples[k];
            const double v[kColumns] = {s.t_s, s.current_a, s.speed_rad_s, s.theta_m_rad, s.hinge_moment_nm, s.command_deg};
            std::memcpy(&row[kColumns * k], v, sizeof v);
        }
        out.write(reinterpret_cast<const char*>(row.data()), static_cast<std::streamsize>(row.size() * sizeof(double)));
    }
    file.commit();
}

Dataset read_dataset(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw EmadiagError("cannot open dataset " + path);
    return read_dataset(in, path);
}

Dataset read_dataset(std::istream& in, const std::string& path) {
    // The body's size follows from the header; it must match the bytes left in the stream, so a
    // header announcing more runs or samples than the file holds is refused before any allocation.
    const std::streampos start = in.tellg();
    std::optional<std::uint64_t> total_bytes;
    if (start != std::streampos(-1) && in.seekg(0, std::ios::end)) {
        total_bytes = static_cast<std::uint64_t>(in.tellg() - start);
        in.seekg(start);
    }
    in.clear();
    char magic[8] = {};
    in.read(magic, sizeof magic);
    if (!in || std::memcmp(magic, kMagic, sizeof magic) != 0) {
        throw EmadiagError(path + ": not an emadiag dataset (magic EMADSET1 missing at byte 0)");
    }
    std::uint64_t length = 0;
    in.read(reinterpret_cast<char*>(&length), sizeof length);
    constexpr std::uint64_t kMaxHeaderBytes = 1 << 20;
    if (!in || length > kMaxHeaderBytes) {
        throw EmadiagError(path + ": header length " + std::to_string(length) + " at byte 8 exceeds " +
                           std::to_string(kMaxHeaderBytes));
    }
    std::string text(length, '\0');
    in.read(text.data(), static_cast<std::streamsize>(length));
    if (!in) throw EmadiagError(path + ": truncated header (" + std::to_string(length) + " bytes announced)");
    Dataset d;
    std::size_t runs = 0, samples_per_run = 0;
    std::string json_error;
    const auto parsed = io::parse_bounded_json(text, json_error);
    if (!parsed) throw EmadiagError(path + ": bad header: " + json_error);
    try {
        const auto& h = *parsed;
        if (h.at("version").get<int>() != kFormatVersion) {
            throw EmadiagError(path + ": header field version " + h.at("version").dump() + " is not " +
                               std::to_string(kFormatVersion));
        }
        d.spec.load_case = sim::parse_load_case(h.at("case").get<std::string>());
        d.spec.sequence = sim::parse_sequence(h.at("sequence").get<std::string>());
        d.spec.noise = sim::parse_noise(h.at("noise").get<std::string>());
        d.spec.seed = h.at("seed").get<std::uint64_t>();
        d.spec.count = h.at("count").get<int>();
        runs = h.at("runs").get<std::size_t>();
        samples_per_run = h.at("samples_per_run").get<std::size_t>();
        const auto& c = h.at("constants");
        d.constants = RunConstants{c.at("k_t_Nm_per_A").get<double>(), c.at("J_kgm2").get<double>(),
                                   c.at("tau").get<double>(), c.at("sample_period_s").get<double>()};
        const auto& f = h.at("filter");
        d.filter = FilterCounts{f.at("simulated").get<int>(), f.at("accepted").get<int>(), f.at("non_finite").get<int>(),
                                f.at("limit_cycle").get<int>(), f.at("non_physical").get<int>()};
    } catch (const nlohmann::json::exception& e) {
        throw EmadiagError(path + ": bad header: " + e.what());
    } catch (const sim::SimError& e) {
        throw EmadiagError(path + ": bad header: " + e.what());
    }
    if (samples_per_run < kMinDatasetSamplesPerRun) {
        throw EmadiagError(path + ": header samples_per_run " + std::to_string(samples_per_run) +
                           " is below the limit kMinDatasetSamplesPerRun = " + std::to_string(kMinDatasetSamplesPerRun));
    }
    {
        const std::pair<const char*, double> constants[] = {{"k_t_Nm_per_A", d.constants.k_t_nm_per_a},
                                                            {"J_kgm2", d.constants.j_kgm2},
                                                            {"tau", d.constants.tau},
                                                            {"sample_period_s", d.constants.sample_period_s}};
        for (const auto& [name, value] : constants) {
            if (!(std::isfinite(value) && value > 0)) {
                throw EmadiagError(path + ": header constant " + name + " = " + format_exact(value) + " is not a finite number > 0");
            }
        }
    }
    if (samples_per_run > kMaxDatasetSamplesPerRun) {
        throw EmadiagError(path + ": header samples_per_run " + std::to_string(samples_per_run) +
                           " exceeds the limit kMaxDatasetSamplesPerRun = " + std::to_string(kMaxDatasetSamplesPerRun));
    }
    const std::uint64_t run_bytes = (kLabelCount + 1 + kColumns * std::uint64_t{samples_per_run}) * sizeof(double);
    if (runs > kMaxDatasetBytes / run_bytes) {
        throw EmadiagError(path + ": header announces " + std::to_string(runs) + " runs of " + std::to_string(samples_per_run) +
                           " samples, more than the limit kMaxDatasetBytes = " + std::to_string(kMaxDatasetBytes) + " bytes");
    }
    const std::uint64_t body = runs * run_bytes, head = sizeof magic + sizeof length + length;
    if (total_bytes && *total_bytes != head + body) {
        throw EmadiagError(path + ": header announces " + std::to_string(runs) + " runs of " + std::to_string(samples_per_run) +
                           " samples (" + std::to_string(head + body) + " bytes) but the file has " + std::to_string(*total_bytes) +
                           " bytes");
    }
    std::vector<double> row(kColumns * samples_per_run);
    d.runs.reserve(std::min<std::size_t>(runs, 4096));  // grows with what is actually read
    for (std::size_t i = 0; i < runs; ++i) {
        double labels[kLabelCount];
        DatasetRun& r = d.runs.emplace_back();
        in.read(reinterpret_cast<char*>(labels), sizeof labels);
        in.read(reinterpret_cast<char*>(&r.noise_seed), sizeof r.noise_seed);
        in.read(reinterpret_cast<char*>(row.data()), static_cast<std::streamsize>(row.size() * sizeof(double)));
        if (!in) {
            throw EmadiagError(path + ": truncated at run " + std::to_string(i) + " of " + std::to_string(runs));
        }
        // Checked as loaded (issue 21 item 11), so training never sees a value it cannot use.
        const std::string where = path + ": run " + std::to_string(i) + ": ";
        for (std::size_t l = 0; l < kLabelCount; ++l) {
            const HealthRange range = health_range(kLabelNames[l]);
            const double slack = kLabelRangeTolerance * (range.hi - range.lo);
            if (!(labels[l] >= range.lo - slack && labels[l] <= range.hi + slack)) {
                throw EmadiagError(where + "label " + kLabelNames[l] + " = " + format_exact(labels[l]) +
                                   " is outside the datasheet's range [" + format_exact(range.lo) + ", " +
                                   format_exact(range.hi) + "] (ema-reference.md section 8)");
            }
        }
        r.labels = HealthLabels{labels[0], labels[1], labels[2], labels[3]};
        r.samples.resize(samples_per_run);
        for (std::size_t k = 0; k < samples_per_run; ++k) {
            const double* v = &row[kColumns * k];
            for (std::size_t c = 0; c < kColumns; ++c) {
                if (!std::isfinite(v[c])) {
                    throw EmadiagError(where + "sample " + std::to_string(k) + ": " + kColumnNames[c] + " = " +
                                       format_exact(v[c]) + " is not finite");
                }
            }
            if (k > 0 && !(v[0] > row[kColumns * (k - 1)])) {
                throw EmadiagError(where + "sample " + std::to_string(k) + ": t_s = " + format_exact(v[0]) +
                                   " does not increase (sample " + std::to_string(k - 1) + ": " +
                                   format_exact(row[kColumns * (k - 1)]) + ")");
            }
            r.samples[k] = sim::Sample{v[0], v[1], v[2], v[3], v[4], v[5]};
        }
    }
    return d;
}

Split split_indices(int n, std::uint64_t seed) {
    std::vector<int> idx(static_cast<std::size_t>(std::max(n, 0)));
    for (int i = 0; i < n; ++i) idx[static_cast<std::size_t>(i)] = i;
    // Fisher-Yates on mt19937_64 by hand (std::shuffle differs between standard libraries).
    std::mt19937_64 rng(seed);
    for (std::size_t i = idx.size(); i > 1; --i) {
        const auto j = static_cast<std::size_t>(uniform01(rng()) * static_cast<double>(i));
        std::swap(idx[i - 1], idx[std::min(j, i - 1)]);
    }
    const auto n_train = static_cast<std::size_t>(std::llround(kTrainFraction * n));
    const auto n_val = static_cast<std::size_t>(std::llround(kValidationFraction * n));
    Split s;
    s.train.assign(idx.begin(), idx.begin() + static_cast<long>(n_train));
    s.validation.assign(idx.begin() + static_cast<long>(n_train), idx.begin() + static_cast<long>(n_train + n_val));
    s.test.assign(idx.begin() + static_cast<long>(n_train + n_val), idx.end());
    return s;
}

}  // namespace emadiag
