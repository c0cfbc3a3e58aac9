// The command line's first word: a subcommand that does not exist is named, with the valid ones.
#pragma once

#include <CLI/CLI.hpp>

namespace texdefrag::cli {

/// When argv[1] is a word (not an option) that names no subcommand of `app`, prints
/// "texdefrag: unknown subcommand 'X' (valid: run, validate, ...)" with the nearest name suggested
/// on stderr and returns 2; otherwise returns 0 and prints nothing.
int check_subcommand_name(CLI::App& app, int argc, char** argv);

}  // namespace texdefrag::cli
