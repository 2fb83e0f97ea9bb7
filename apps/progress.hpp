#pragma once
// Progress of a long command on stderr, with elapsed time and ETA: a redrawn bar on a terminal,
// else info log lines (so --quiet and --log-level warn silence them). Shared by run, bench,
// render, audit and the multi-run commands (ablate, sweep): one reporter per loop.
#include <chrono>
#include <string>

namespace ccfr::app {

/// --quiet: no progress, logs at warn and above; results still go to stdout.
void set_quiet(bool quiet);
bool quiet();

/// "0.84 s", "42 s", "3 min 05 s", "2 h 07 min".
std::string format_duration(double seconds);

class ProgressReporter {
 public:
  /// `label` starts each line ("run twisting_cloth", "ablate ccfr"); `total` steps (frames).
  /// `log_every_s`: without a terminal, at most one line per this many seconds (0: every call;
  /// the first call and the last step are always reported).
  ProgressReporter(std::string label, long total, double log_every_s = 0.0);
  ~ProgressReporter();
  ProgressReporter(const ProgressReporter&) = delete;
  ProgressReporter& operator=(const ProgressReporter&) = delete;

  /// Reports `done` of total steps finished; `detail` follows the counts (per-step figures).
  void update(long done, const std::string& detail = std::string());
  /// Erases the bar before the caller prints other lines to the same terminal.
  void clear();
  /// Ends the bar's line (also done by the destructor).
  void finish();

  double elapsed_s() const;
  /// Remaining time extrapolated from the mean time per step so far; negative before step 1.
  double eta_s(long done) const;
  bool on_terminal() const { return tty_; }

 private:
  std::string label_;
  long total_;
  double log_every_s_;
  bool tty_ = false, enabled_ = true, drawn_ = false, logged_ = false;
  std::chrono::steady_clock::time_point start_;
  double last_log_s_ = -1e300;
};

}  // namespace ccfr::app
