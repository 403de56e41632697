// Running gnuplot on a script the report writes: finding it on PATH, quoting for its scripts and data
// files, and running it with its output in a log. Internal to dh_report (plots.cpp, climb.cpp).
#pragma once

#include <filesystem>
#include <string>

namespace dh::report::gnuplot {

/// gnuplot's path on PATH; empty when it is not there.
std::filesystem::path find();
/// A gnuplot single-quoted string: no escapes inside, a quote is doubled.
std::string quote(const std::string& s);
/// A string column of a gnuplot data file: double-quoted, so it may hold spaces but no double quote.
std::string data_label(const std::string& s);
bool write_file(const std::filesystem::path& path, const std::string& text);
/// Runs `program script` with stdout and stderr in `log`; returns the exit status, or −1 if it did not run.
int run(const std::filesystem::path& program, const std::filesystem::path& script,
        const std::filesystem::path& log);
/// The script's first lines: a PNG terminal of `width` x `height` (pngcairo when gnuplot has it).
std::string png_terminal(int width, int height);

}  // namespace dh::report::gnuplot
