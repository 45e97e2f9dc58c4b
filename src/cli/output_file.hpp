#pragma once
// Writing a command's output to --out FILE whole (emadiag/io/output_path.hpp: a unique temporary
// file, fsynced and renamed into place; never over an input, the database, a device, a FIFO or a
// link) or to stdout when no file is given; and the CSV cell writer (emadiag/io/text_field.hpp).
#include "core/emadiag_error.hpp"
#include "emadiag/io/output_path.hpp"
#include "emadiag/io/text_field.hpp"
#include "emadiag/io/uri.hpp"

#include <iostream>
#include <string>

namespace emadiag::cli {

/// `text` to the file `path` (refused when it is one of `inputs`), or to stdout when path is empty.
inline void write_output(const std::string& path, const std::string& text, const io::OutputInputs& inputs = {}) {
    if (path.empty()) {
        std::cout << text << std::flush;
        return;
    }
    io::write_output_file<EmadiagError>(path, "output", inputs, text);
}

/// The --db of a report as an input to protect: a SQLite file (a fleet server URI is no file).
inline io::OutputInputs database_input(const std::string& db) {
    if (io::has_uri_scheme(db)) return {};
    return io::OutputInputs({}, {db});
}

using io::csv_field;
using io::escape_text;

}  // namespace emadiag::cli
