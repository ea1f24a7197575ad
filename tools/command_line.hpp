#pragma once
// Command-line parsing every program shares: a wrong option, a missing argument or an input file
// that is not there is an input error, exit status 2 (docs/architecture.md), whatever code CLI11
// gives it; --help and --version print on stdout and exit 0.
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

namespace skylit::tools {

// Parses argv into `app`. nullopt when the program is to go on; else the status for main to
// return, the help, version or error already printed. Errors read as every other input error:
// "PROGRAM: error: CLI11'S MESSAGE. Fix: ...".
inline std::optional<int> parse_command_line(CLI::App& app, int argc, const char* const* argv) {
  const std::string program =
      app.get_name().empty() && argc > 0 ? std::filesystem::path(argv[0]).filename().string()
                                         : std::filesystem::path(app.get_name()).filename().string();
  app.failure_message([program](const CLI::App*, const CLI::Error& e) {
    const std::string fix = dynamic_cast<const CLI::ValidationError*>(&e) != nullptr
                                ? "give an existing file or a valid value"
                                : "correct the command line";
    return program + ": error: " + e.what() + ". Fix: " + fix + " (" + program + " --help lists the options)\n";
  });
  try {
    app.parse(argc, argv);
    return std::nullopt;
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
}

// --version: "PROGRAM VERSION", the project's version (CMakeLists.txt) for every program.
inline void add_version_flag(CLI::App& app) {
  app.set_version_flag("--version", app.get_name() + " " + SKYLIT_VERSION);
}

// -q, --quiet for a program whose stdout carries only its reports and progress, and stderr its
// warnings and errors: quiet_stdout() after parsing sends stdout to /dev/null.
inline void add_quiet_flag(CLI::App& app, bool& quiet) {
  app.add_flag("-q,--quiet", quiet, "only warnings and errors");
}
inline void quiet_stdout() {
  if (std::freopen("/dev/null", "w", stdout) == nullptr) std::fclose(stdout);
}

}  // namespace skylit::tools
