// The tools' command lines (fem_cloth_sim, _render, _report, _validate, _materials): one
// convention for a command line that does not parse.
#pragma once

#include <CLI/CLI.hpp>

#include <cmath>
#include <iostream>
#include <optional>
#include <string>

namespace fem_cloth {

/// Parses `app`. --help prints the usage: exit status 0. Any other error is one line on stderr,
/// "<program>: <what, naming the option> (see --help)", exit status 2 (not CLI11's own codes,
/// 105 for a value its check refuses, nor its two-line report without the program's name).
/// None when the program goes on.
inline std::optional<int> parseToolCommandLine(CLI::App& app, int argc, char** argv, const std::string& program) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);
    std::cerr << program << ": " << e.what() << " (see --help)\n";
    return 2;
  }
  return std::nullopt;
}

/// The check of an option that takes a positive, finite number; its message (after CLI11's
/// "--option: ") reads "must be a positive, finite number, got -1" (CLI::PositiveNumber's names
/// the largest double).
inline CLI::Validator positiveNumber() {
  return CLI::Validator(
      [](std::string& text) {
        double x = 0.0;
        const bool ok = CLI::detail::lexical_cast(text, x) && x > 0.0 && std::isfinite(x);
        return ok ? std::string() : "must be a positive, finite number, got " + text;
      },
      "POSITIVE");
}

}  // namespace fem_cloth
