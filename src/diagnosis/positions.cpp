#include "diagnosis/positions.hpp"

#include "core/emadiag_error.hpp"
#include "emadiag/db/record_store.hpp"
#include "emadiag/db/sha256.hpp"

#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>

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

namespace {

std::string read_positions_file(const std::string& path) {
    // Opened without blocking (a FIFO would otherwise wait for a writer), then checked on the open
    // descriptor: only a regular file of at most kMaxPositionsFileBytes is read, in bounded chunks.
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) throw EmadiagError(path + ": cannot read the positions file: " + std::strerror(errno));
    struct Closer {
        int fd;
        ~Closer() { ::close(fd); }
    } closer{fd};
    struct stat st {};
    if (::fstat(fd, &st) != 0) throw EmadiagError(path + ": cannot read the positions file: " + std::strerror(errno));
    if (!S_ISREG(st.st_mode)) throw EmadiagError(path + ": the positions file is not a regular file");
    const auto too_large = [&] {
        return EmadiagError(path + ": the positions file is larger than the limit kMaxPositionsFileBytes = " +
                            std::to_string(kMaxPositionsFileBytes) + " bytes");
    };
    if (static_cast<std::uint64_t>(st.st_size) > kMaxPositionsFileBytes) throw too_large();
    std::string text;
    char buf[4096];
    for (;;) {
        const ssize_t n = ::read(fd, buf, sizeof buf);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) throw EmadiagError(path + ": read error on the positions file: " + std::strerror(errno));
        if (n == 0) break;
        text.append(buf, static_cast<std::size_t>(n));
        if (text.size() > kMaxPositionsFileBytes) throw too_large();  // it grew while read
    }
    return text;
}

std::optional<std::string> description_problem(const std::string& d) {
    if (d.size() > kMaxPositionDescriptionChars) {
        return "description of " + std::to_string(d.size()) + " characters is longer than the limit kMaxPositionDescriptionChars = " +
               std::to_string(kMaxPositionDescriptionChars);
    }
    for (const char c : d) {
        if (std::iscntrl(static_cast<unsigned char>(c))) return std::string("description holds a control character");
    }
    return std::nullopt;
}

}  // namespace

PositionList PositionList::load(const std::string& path) {
    const std::string text = read_positions_file(path);
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {
        throw EmadiagError(path + ": not JSON: " + e.what());
    }
    if (!j.is_object() || !j.contains("positions") || !j["positions"].is_array() || j["positions"].empty())
        throw EmadiagError(path + ": expected {\"positions\": [{\"name\": ..., \"ata\": ..., \"description\": ...}, ...]} with at least one position");
    if (j["positions"].size() > kMaxPositions) {
        throw EmadiagError(path + ": " + std::to_string(j["positions"].size()) + " positions, more than the limit kMaxPositions = " +
                           std::to_string(kMaxPositions));
    }
    PositionList l;
    std::vector<std::string> problems;
    for (std::size_t i = 0; i < j["positions"].size(); ++i) {
        const auto& e = j["positions"][i];
        const std::string where = "position " + std::to_string(i) + ": ";
        if (!e.is_object() || !e.contains("name") || !e["name"].is_string() || !e.contains("ata") || !e["ata"].is_string()) {
            problems.push_back(where + "needs \"name\" and \"ata\" strings");
            continue;
        }
        if (e.contains("description") && !e["description"].is_string()) {
            problems.push_back(where + "\"description\" must be a string");
            continue;
        }
        Position p{e["name"].get<std::string>(), e["ata"].get<std::string>(), e.value("description", std::string{})};
        if (const auto bad = description_problem(p.description)) problems.push_back(where + *bad);
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
    l.sha256 = db::sha256_hex(text);
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
