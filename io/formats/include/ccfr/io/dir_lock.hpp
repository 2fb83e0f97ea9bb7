#pragma once
/// @file dir_lock.hpp
/// One writer per directory ccfr writes (a run, an ablation, a sweep, a sweep's cell): an exclusive
/// flock(2) on DIR/.ccfr-lock, held for as long as the writer lives, plus a record of the holder
/// (pid, host, command, start time) inside the file for the message a second writer gets. The
/// kernel releases a flock when its process dies, so a lock left by a killed process is stale by
/// construction and is taken over (and said so). docs/output.md, "One writer per directory".
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

namespace ccfr::io {

/// The lock file's name inside a locked directory: one of ccfr's own files, never user content.
inline constexpr const char* kLockFileName = ".ccfr-lock";

/// Who holds (or last held) a directory's lock, from the record in its lock file.
struct LockHolder {
  long pid = 0;  ///< 0 when the record is missing or unreadable
  std::string host, command, start_time;
  /// "pid 123 on host h since 2026-01-01T00:00:00Z: ccfr run a.yaml --out d"
  std::string describe() const;
};

/// An exclusive lock on a directory. Copies share one hold; the lock is released (and its file
/// removed) when the last copy goes. Taking the lock of a directory this process already holds
/// shares that hold, so nested writers (`sweep run-cell` -> run -> RunWriter) need no plumbing.
class DirLock {
 public:
  DirLock() = default;
  /// Takes the lock of `dir`, creating `dir` when it is missing (removed again on release if it
  /// is still empty then). `command` is recorded for a second writer's message. Throws ccfr::Error
  /// when another process holds it (naming its pid, host, start time and command), when `dir`
  /// exists and is not a directory, or when the lock file cannot be created.
  static DirLock acquire(const std::filesystem::path& dir, const std::string& command);
  bool held() const { return state_ != nullptr; }
  /// Releases this copy's share of the hold.
  void release() { state_.reset(); }

  struct State;

 private:
  std::shared_ptr<State> state_;
};

/// The holder of `dir`'s lock if a live process holds it now; nullopt otherwise (no lock file, or
/// a stale one). Never creates the lock file; when this process holds the lock, it is reported too.
std::optional<LockHolder> lock_holder(const std::filesystem::path& dir);

/// True when `dir` is missing or holds nothing but ccfr's lock file.
bool dir_is_empty(const std::filesystem::path& dir);

/// ISO-8601 UTC timestamp of now (the lock record's start time; run.json's times).
std::string utc_now();

}  // namespace ccfr::io
