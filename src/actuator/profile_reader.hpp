#pragma once
// Reads the fields of one profile file and collects every problem, each "SOURCE: /json/path:
// message" with the value and the allowed range; thrown together at the end (throw_if_any). Every
// key of the schema is required: a value the documentation does not give is written null, so an
// unknown value is said explicitly and a forgotten one is an error. Internal to src/actuator/.
#include <nlohmann/json.hpp>

#include <cstddef>
#include <initializer_list>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace emadiag::actuator::detail {

/// The range a number must be in.
enum class Bound { finite, positive, non_negative, efficiency };
/// Whether null (unknown) is accepted.
enum class Null { allowed, refused };

class ProfileReader {
public:
    explicit ProfileReader(std::string source) : source_(std::move(source)) {}

    void problem(const std::string& path, const std::string& message);
    [[nodiscard]] bool any() const { return !problems_.empty(); }
    /// Throws ActuatorError "actuator profile SOURCE: N problems" and the list, if any.
    void throw_if_any() const;

    /// Keys of `obj` outside `allowed` are problems, as are the keys of `allowed` missing from it.
    void keys(const nlohmann::json& obj, const std::string& path, std::initializer_list<const char*> allowed);

    /// The object at obj[key]; nullptr (with a problem unless null is allowed and given) otherwise.
    const nlohmann::json* object(const nlohmann::json& obj, const std::string& path, const char* key, Null null);
    /// The number at obj[key] within `bound`; nullopt when null or wrong (a problem unless allowed null).
    std::optional<double> number(const nlohmann::json& obj, const std::string& path, const char* key, Bound bound, Null null);
    /// A count >= `min`.
    std::optional<std::size_t> count(const nlohmann::json& obj, const std::string& path, const char* key, std::size_t min);
    /// A string of 1..max_chars printable characters (tab and line breaks refused).
    std::optional<std::string> text(const nlohmann::json& obj, const std::string& path, const char* key, std::size_t max_chars, Null null);
    /// One of `names` (index into it); a problem listing them otherwise.
    std::optional<std::size_t> choice(const nlohmann::json& obj, const std::string& path, const char* key,
                                      const std::vector<const char*>& names, Null null);
    /// The elements of the array obj[key] (at most kMaxProfileEntries), each with its path.
    std::vector<std::pair<std::string, const nlohmann::json*>> array(const nlohmann::json& obj, const std::string& path,
                                                                     const char* key, Null null);
    /// [low, high] of two finite numbers with low < high, or null when allowed.
    std::optional<std::pair<double, double>> interval(const nlohmann::json& obj, const std::string& path, const char* key, Null null);
    /// Finite numbers of an array of 1..max_count entries.
    std::optional<std::vector<double>> numbers(const nlohmann::json& value, const std::string& path, std::size_t max_count);

    /// "> 0", "in (0, 1]", ... (the range in messages)
    [[nodiscard]] static std::string bound_text(Bound bound);

private:
    std::string source_;
    std::vector<std::string> problems_;
};

}  // namespace emadiag::actuator::detail
