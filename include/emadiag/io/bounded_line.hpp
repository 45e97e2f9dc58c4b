#pragma once
// std::getline that stores at most `max_bytes` of a line (the rest is skipped, `too_long` set), so
// one enormous line cannot make a reader allocate without limit. Shared by the candump and the
// run CSV readers.
#include <cstddef>
#include <istream>
#include <string>

namespace emadiag::io {

inline bool read_bounded_line(std::istream& in, std::string& line, std::size_t max_bytes, bool& too_long) {
    line.clear();
    too_long = false;
    std::streambuf* sb = in.rdbuf();
    bool any = false;
    for (;;) {
        const int c = sb->sbumpc();
        if (c == std::char_traits<char>::eof()) {
            in.setstate(std::ios::eofbit);
            return any;
        }
        any = true;
        if (c == '\n') return true;
        if (line.size() < max_bytes) line.push_back(static_cast<char>(c));
        else too_long = true;  // the rest of the line is skipped, never stored
    }
}

}  // namespace emadiag::io
