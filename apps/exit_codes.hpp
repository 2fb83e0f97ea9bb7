#pragma once
// The exit codes of every ccfr command, one table: `ccfr --help` prints it and docs/cli.md is
// generated from it (`ccfr help-markdown`), so the two cannot drift.
#include <string>

namespace ccfr::app {

/// An uncaught exception (a bug in ccfr, not in the input): sysexits' EX_SOFTWARE, apart from
/// every documented outcome (3 is a baseline's completed run with violations).
inline constexpr int kExitInternalError = 70;

struct ExitCodeRow {
  int code;
  const char* meaning;
};

inline constexpr ExitCodeRow kExitCodes[] = {
    {0, "success"},
    {1, "the command ran and found a failure: a failed audit, a failed cell, a run stopped early (docs/output.md)"},
    {2, "bad input: a message names the file, key path and line, or the option"},
    {3, "ccfr run: completed under a solver without the separation guarantee with violations left in some frames"},
    {4, "ccfr audit: the frames are clean but the run did not complete (without --partial)"},
    {kExitInternalError, "internal error (a bug in ccfr: please report it with the command line)"},
};

/// The table as plain text lines ("  0  success"), for --help.
inline std::string exit_code_text() {
  std::string s = "Exit codes:\n";
  for (const ExitCodeRow& r : kExitCodes) s += "  " + std::to_string(r.code) + "\t" + r.meaning + "\n";
  return s;
}

/// The table in Markdown, for docs/cli.md.
inline std::string exit_code_markdown() {
  std::string s = "| exit code | meaning |\n|---|---|\n";
  for (const ExitCodeRow& r : kExitCodes) s += "| " + std::to_string(r.code) + " | " + r.meaning + " |\n";
  return s;
}

}  // namespace ccfr::app
