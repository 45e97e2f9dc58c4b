#include "diagnosis/positions.hpp"

#include "core/emadiag_error.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/sha256.hpp"

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <fstream>
#include <sstream>

namespace emadiag {
namespace {

nlohmann::json to_json(const std::vector<Position>& positions) {
    nlohmann::json arr = nlohmann::json::array();
    for (const auto& p : positions) arr.push_back({{"name", p.name}, {"ata", p.ata}, {"description", p.description}});
    return {{"positions", arr}};
}

}  // namespace

PositionList PositionList::defaults() {
    // ATA iSpec 2200 chapter 27: 27-10 aileron, 27-20 rudder, 27-30 elevator, 27-40 horizontal
    // stabilizer, 27-50 flaps, 27-60 spoilers.
    PositionList l;
    l.positions = {
        {"LH-AIL", "27-10", "left aileron"},          {"RH-AIL", "27-10", "right aileron"},
        {"RUDDER", "27-20", "rudder"},                {"LH-ELEV", "27-30", "left elevator"},
        {"RH-ELEV", "27-30", "right elevator"},       {"THS", "27-40", "trimmable horizontal stabilizer"},
        {"LH-FLAP", "27-50", "left flap"},            {"RH-FLAP", "27-50", "right flap"},
        {"LH-SPLR", "27-60", "left spoiler"},         {"RH-SPLR", "27-60", "right spoiler"},
    };
    l.source = "built-in";
    l.sha256 = db::sha256_hex(to_json(l.positions).dump());
    return l;
}

PositionList PositionList::load(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw EmadiagError(path + ": cannot read the positions file");
    std::ostringstream text;
    text << in.rdbuf();
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(text.str());
    } catch (const nlohmann::json::exception& e) {
        throw EmadiagError(path + ": not JSON: " + e.what());
    }
    if (!j.is_object() || !j.contains("positions") || !j["positions"].is_array() || j["positions"].empty())
        throw EmadiagError(path + ": expected {\"positions\": [{\"name\": ..., \"ata\": ..., \"description\": ...}, ...]} with at least one position");
    PositionList l;
    std::vector<std::string> problems;
    for (std::size_t i = 0; i < j["positions"].size(); ++i) {
        const auto& e = j["positions"][i];
        const std::string where = "position " + std::to_string(i) + ": ";
        if (!e.is_object() || !e.contains("name") || !e["name"].is_string() || !e.contains("ata") || !e["ata"].is_string()) {
            problems.push_back(where + "needs \"name\" and \"ata\" strings");
            continue;
        }
        Position p{e["name"].get<std::string>(), e["ata"].get<std::string>(), e.value("description", std::string{})};
        if (const auto bad = db::position_problem(p.name)) problems.push_back(where + *bad);
        if (const auto bad = db::ata_reference_problem(p.ata)) problems.push_back(where + *bad);
        for (const auto& q : l.positions)
            if (q.name == p.name) problems.push_back(where + "'" + p.name + "' is listed twice");
        l.positions.push_back(std::move(p));
    }
    if (!problems.empty()) {
        std::string msg = path + ": " + std::to_string(problems.size()) + " problem(s) in the positions file";
        for (const auto& p : problems) msg += "\n  " + path + ": " + p;
        throw EmadiagError(msg);
    }
    l.source = path;
    l.sha256 = db::sha256_hex(text.str());
    return l;
}

PositionList PositionList::resolve(const std::string& path) {
    if (!path.empty()) return load(path);
    if (const char* env = std::getenv(kPositionsEnv); env != nullptr && *env != '\0') return load(env);
    return defaults();
}

const Position& PositionList::find(const std::string& name) const {
    for (const auto& p : positions)
        if (p.name == name) return p;
    throw EmadiagError("unknown position '" + name + "' (known positions, " + source + ": " + names() +
                       "; docs/fleet-record.md says how to configure them)");
}

std::string PositionList::names() const {
    std::string out;
    for (std::size_t i = 0; i < positions.size(); ++i) out += (i ? ", " : "") + positions[i].name;
    return out;
}

}  // namespace emadiag
