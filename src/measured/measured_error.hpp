#pragma once
// The one exception type of the measured-run import (issue 23 part 2): a column map that cannot be
// used, or a data file that does not match its map. Every message starts with "[measured] " and
// names the file, the line, the column and the value (or the map's field and its value).
#include <stdexcept>
#include <string>

namespace emadiag::measured {

class MeasuredError : public std::runtime_error {
public:
    explicit MeasuredError(const std::string& what) : std::runtime_error("[measured] " + what) {}
};

}  // namespace emadiag::measured
