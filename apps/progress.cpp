#include "progress.hpp"

#include <unistd.h>

#include <spdlog/spdlog.h>
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "ccfr/core/log.hpp"

namespace ccfr::app {

namespace {
bool g_quiet = false;
}

void set_quiet(bool q) { g_quiet = q; }
bool quiet() { return g_quiet; }

std::string format_duration(double s) {
  char b[48];
  if (!std::isfinite(s) || s < 0) return "?";
  if (s < 10)
    std::snprintf(b, sizeof b, "%.2f s", s);
  else if (s < 60)
    std::snprintf(b, sizeof b, "%.0f s", s);
  else if (s < 3600) {
    const long t = std::lround(s);
    std::snprintf(b, sizeof b, "%ld min %02ld s", t / 60, t % 60);
  } else {
    const long t = std::lround(s / 60);
    std::snprintf(b, sizeof b, "%ld h %02ld min", t / 60, t % 60);
  }
  return b;
}

ProgressReporter::ProgressReporter(std::string label, long total, double log_every_s)
    : label_(std::move(label)),
      total_(total),
      log_every_s_(log_every_s),
      tty_(::isatty(STDERR_FILENO) != 0),
      enabled_(!quiet()),
      start_(std::chrono::steady_clock::now()) {}

ProgressReporter::~ProgressReporter() { finish(); }

double ProgressReporter::elapsed_s() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

double ProgressReporter::eta_s(long done) const {
  if (done <= 0) return -1.0;
  return elapsed_s() / static_cast<double>(done) * static_cast<double>(std::max(total_ - done, 0L));
}

void ProgressReporter::update(long done, const std::string& detail) {
  if (!enabled_) return;
  const double t = elapsed_s();
  const std::string times =
      "elapsed " + format_duration(t) + (done < total_ ? ", ETA " + format_duration(eta_s(done)) : std::string());
  if (tty_) {
    const int width = 24;
    const int filled = total_ > 0 ? static_cast<int>(width * std::min(done, total_) / total_) : width;
    // \033[K erases what a longer previous line left behind.
    std::fprintf(stderr, "\r%s [%.*s%*s] %ld/%ld  %s%s%s\033[K", label_.c_str(), filled, "########################",
                 width - filled, "", done, total_, times.c_str(), detail.empty() ? "" : "  ", detail.c_str());
    std::fflush(stderr);
    drawn_ = true;
    if (done >= total_) finish();
    return;
  }
  if (logged_ && done < total_ && t - last_log_s_ < log_every_s_) return;
  logged_ = true;
  last_log_s_ = t;
  spdlog::info("{} {}/{}: {}{}{}", label_, done, total_, times, detail.empty() ? "" : "; ", detail);
}

void ProgressReporter::clear() {
  if (!drawn_) return;
  std::fputs("\r\033[K", stderr);
  std::fflush(stderr);
  drawn_ = false;
}

void ProgressReporter::finish() {
  if (!drawn_) return;
  std::fputc('\n', stderr);
  std::fflush(stderr);
  drawn_ = false;
}

}  // namespace ccfr::app
