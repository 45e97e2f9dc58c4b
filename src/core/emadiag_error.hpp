#pragma once
#include <stdexcept>
#include <string>

namespace emadiag {

/// The one exception type of the diagnosis core and the CLI; messages start with "[emadiag] ".
class EmadiagError : public std::runtime_error {
public:
    explicit EmadiagError(const std::string& message) : std::runtime_error("[emadiag] " + without_nul(message)) {}

private:
    /// what() is a C string: a NUL byte quoted from the input would end the message there, so it is
    /// written as \0 (issue 21 item 15).
    static std::string without_nul(const std::string& message) {
        if (message.find('\0') == std::string::npos) return message;
        std::string out;
        for (const char c : message) {
            if (c == '\0') out += "\\0";
            else out += c;
        }
        return out;
    }
};

}  // namespace emadiag
