#include "emadiag/sim/terms.hpp"

#include "emadiag/sim/sim_error.hpp"
#include "term_eval.hpp"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <numbers>
#include <sstream>

namespace emadiag::sim {
namespace {

struct SignalName {
    TermSignal signal;
    const char* name;
};
constexpr SignalName kSignals[] = {
    {TermSignal::Speed, "w"},       {TermSignal::ThetaMotor, "theta_m"}, {TermSignal::ThetaSurface, "theta_u"},
    {TermSignal::LoadTorque, "F_R"}, {TermSignal::Time, "t"},            {TermSignal::Current, "I"},
};
struct TargetName {
    TermTarget target;
    const char* name;
};
constexpr TargetName kTargets[] = {
    {TermTarget::Torque, "torque"}, {TermTarget::Current, "current"}, {TermTarget::Speed, "speed"},
    {TermTarget::Theta, "theta"},   {TermTarget::Hinge, "hinge"},
};
struct BasisName {
    TermBasis basis;
    const char* name;
    int params;
};
constexpr BasisName kBases[] = {
    {TermBasis::Abs, "abs", 0},  {TermBasis::Sgn, "sgn", 0},     {TermBasis::Square, "sq", 0}, {TermBasis::Sin, "sin", 1},
    {TermBasis::Cos, "cos", 1},  {TermBasis::Gauss, "gauss", 2}, {TermBasis::Step, "step", 1},
};

std::string num(double v) {
    std::ostringstream os;
    os.precision(8);
    os << v;
    return os.str();
}

std::string factor_text(const TermFactor& f) {
    std::string sig = to_string(f.signal);
    for (const auto& b : kBases) {
        if (b.basis != f.basis) continue;
        std::string s = std::string(b.name) + "(" + sig;
        if (b.params >= 1) s += ", " + num(f.a);
        if (b.params >= 2) s += ", " + num(f.b);
        return s + ")";
    }
    return sig;
}

/// A small recursive-descent reader of the text form.
class Reader {
public:
    explicit Reader(const std::string& text) : s_(text) {}

    Term term() {
        Term t;
        skip();
        // Optional target.
        const std::size_t colon = s_.find(':');
        if (colon != std::string::npos) {
            std::string name = s_.substr(0, colon);
            while (!name.empty() && std::isspace(static_cast<unsigned char>(name.back()))) name.pop_back();
            while (!name.empty() && std::isspace(static_cast<unsigned char>(name.front()))) name.erase(0, 1);
            bool found = false;
            for (const auto& tg : kTargets) {
                if (name == tg.name) {
                    t.target = tg.target;
                    found = true;
                }
            }
            if (!found) fail("a target (torque, current, speed, theta, hinge) before ':'", "'" + name + "'");
            pos_ = colon + 1;
        }
        skip();
        bool have_coefficient = false;
        t.coefficient = 1.0;
        if (pos_ < s_.size() && (std::isdigit(static_cast<unsigned char>(s_[pos_])) || s_[pos_] == '-' ||
                                 s_[pos_] == '+' || s_[pos_] == '.')) {
            t.coefficient = number();
            have_coefficient = true;
            skip();
            if (pos_ == s_.size()) return t;
            expect('*');
        }
        for (;;) {
            t.factors.push_back(factor());
            skip();
            if (pos_ == s_.size()) break;
            expect('*');
        }
        (void)have_coefficient;
        return t;
    }

private:
    [[noreturn]] void fail(const std::string& expected, const std::string& got = {}) const {
        throw SimError("term '" + s_ + "': expected " + expected + " at character " + std::to_string(pos_ + 1) +
                       (got.empty() ? "" : ", got " + got));
    }
    void skip() {
        while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
    }
    void expect(char c) {
        skip();
        if (pos_ >= s_.size() || s_[pos_] != c) fail(std::string("'") + c + "'");
        ++pos_;
        skip();
    }
    double number() {
        skip();
        const char* begin = s_.c_str() + pos_;
        char* end = nullptr;
        const double v = std::strtod(begin, &end);
        if (end == begin || !std::isfinite(v)) fail("a finite number");
        pos_ += static_cast<std::size_t>(end - begin);
        return v;
    }
    std::string word() {
        skip();
        const std::size_t start = pos_;
        while (pos_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[pos_])) || s_[pos_] == '_')) ++pos_;
        if (pos_ == start) fail("a name");
        return s_.substr(start, pos_ - start);
    }
    TermSignal signal() {
        const std::size_t at = pos_;
        const std::string name = word();
        for (const auto& sg : kSignals) {
            if (name == sg.name) return sg.signal;
        }
        pos_ = at;
        fail("a signal (w, theta_m, theta_u, F_R, t, I)", "'" + name + "'");
    }
    TermFactor factor() {
        skip();
        const std::size_t at = pos_;
        const std::string name = word();
        skip();
        TermFactor f;
        if (pos_ < s_.size() && s_[pos_] == '(') {
            const BasisName* basis = nullptr;
            for (const auto& b : kBases) {
                if (name == b.name) basis = &b;
            }
            if (basis == nullptr) {
                pos_ = at;
                fail("a function (abs, sgn, sq, sin, cos, gauss, step)", "'" + name + "'");
            }
            f.basis = basis->basis;
            expect('(');
            f.signal = signal();
            if (basis->params >= 1) {
                expect(',');
                f.a = number();
            }
            if (basis->params >= 2) {
                expect(',');
                f.b = number();
            }
            expect(')');
            return f;
        }
        pos_ = at;
        f.signal = signal();
        return f;
    }

    const std::string& s_;
    std::size_t pos_ = 0;
};

}  // namespace

std::string to_string(TermTarget t) {
    for (const auto& tg : kTargets) {
        if (tg.target == t) return tg.name;
    }
    return "?";
}

std::string to_string(TermSignal s) {
    for (const auto& sg : kSignals) {
        if (sg.signal == s) return sg.name;
    }
    return "?";
}

std::string Term::basis_text() const {
    if (factors.empty()) return "1";
    std::string s;
    for (const auto& f : factors) {
        if (!s.empty()) s += '*';
        s.append(factor_text(f));
    }
    return s;
}

std::string Term::text() const {
    std::string s = to_string(target);
    s.append(": ");
    s.append(num(coefficient));
    if (!factors.empty()) {
        s += '*';
        s.append(basis_text());
    }
    return s;
}

double term_basis(const Term& term, const TermInputs& x) {
    double v = 1.0;
    for (const auto& f : term.factors) v *= detail::factor_value(f, detail::signal_value(f.signal, x));
    return v;
}

double sum_terms(const std::vector<Term>& terms, TermTarget target, const TermInputs& x) {
    double v = 0.0;
    for (const auto& t : terms) {
        if (t.target == target) v += term_value(t, x);
    }
    return v;
}

void validate_term(const Term& t, const std::string& where) {
    std::string problems;
    if (!std::isfinite(t.coefficient)) problems += "\n  " + where + ".coefficient = " + num(t.coefficient) + " is not finite";
    if (!std::isfinite(t.std_error) || t.std_error < 0) {
        problems += "\n  " + where + ".std_error = " + num(t.std_error) + " must be finite and >= 0";
    }
    for (std::size_t i = 0; i < t.factors.size(); ++i) {
        const auto& f = t.factors[i];
        const std::string at = where + " factor " + std::to_string(i + 1) + " (" + factor_text(f) + ")";
        if (!std::isfinite(f.a) || !std::isfinite(f.b)) problems += "\n  " + at + ": parameters must be finite";
        if ((f.basis == TermBasis::Sin || f.basis == TermBasis::Cos) && !(f.a > 0)) {
            problems += "\n  " + at + ": the period must be > 0";
        }
        if (f.basis == TermBasis::Gauss && !(f.b > 0)) problems += "\n  " + at + ": the width must be > 0";
    }
    if (!problems.empty()) throw SimError("invalid term:" + problems);
}

Term parse_term(const std::string& text) {
    Reader r(text);
    Term t = r.term();
    validate_term(t, "term '" + text + "'");
    return t;
}

nlohmann::json to_json(const Term& t) {
    return {{"target", to_string(t.target)}, {"basis", t.basis_text()}, {"coefficient", t.coefficient},
            {"std_error", t.std_error}};
}

Term term_from_json(const nlohmann::json& j, const std::string& where) {
    if (j.is_string()) {
        try {
            return parse_term(j.get<std::string>());
        } catch (const SimError& e) {
            throw SimError(where + ": " + e.what());
        }
    }
    if (!j.is_object()) throw SimError(where + ": expected a term object or its text form");
    std::string problems;
    for (const auto& [key, value] : j.items()) {
        if (key != "target" && key != "basis" && key != "coefficient" && key != "std_error" && key != "name" &&
            key != "physics") {
            problems += "\n  " + where + "." + key + ": unknown key (target, basis, coefficient, std_error, name, physics)";
        }
    }
    if (!j.contains("basis") || !j["basis"].is_string()) problems += "\n  " + where + ".basis: expected a string";
    if (!j.contains("coefficient") || !j["coefficient"].is_number()) {
        problems += "\n  " + where + ".coefficient: expected a number";
    }
    if (j.contains("target") && !j["target"].is_string()) problems += "\n  " + where + ".target: expected a string";
    if (j.contains("std_error") && !j["std_error"].is_number()) problems += "\n  " + where + ".std_error: expected a number";
    if (!problems.empty()) throw SimError("invalid term:" + problems);
    const std::string target = j.value("target", std::string("torque"));
    const std::string basis = j["basis"].get<std::string>();
    Term t;
    try {
        t = parse_term(target + ": " + (basis == "1" ? std::string("1") : "1*" + basis));
    } catch (const SimError& e) {
        throw SimError(where + ": " + e.what());
    }
    t.coefficient = j["coefficient"].get<double>();
    t.std_error = j.value("std_error", 0.0);
    validate_term(t, where);
    return t;
}

}  // namespace emadiag::sim
