#include "ccfr/io/dir_lock.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"

namespace ccfr::io {

std::string utc_now() {
  std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

namespace fs = std::filesystem;

struct DirLock::State {
  int fd = -1;
  fs::path dir, file;
  std::pair<dev_t, ino_t> key{};
  bool created_dir = false;
  State() = default;
  State(const State&) = delete;
  State& operator=(const State&) = delete;
  ~State();
};

namespace {

// Holds taken by this process, by the directory's device and inode (one directory may be named by
// several paths): a second acquire shares the hold instead of deadlocking on its own flock.
std::mutex& registry_mutex() {
  static std::mutex m;
  return m;
}
std::map<std::pair<dev_t, ino_t>, std::weak_ptr<DirLock::State>>& registry() {
  static std::map<std::pair<dev_t, ino_t>, std::weak_ptr<DirLock::State>> r;
  return r;
}

std::string host_name() {
  char h[256] = "";
  ::gethostname(h, sizeof h - 1);
  return h;
}

bool process_alive(long pid) { return pid > 0 && (::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM); }

LockHolder read_record(int fd) {
  std::string text(65536, '\0');
  const ssize_t n = ::pread(fd, text.data(), text.size(), 0);
  text.resize(n > 0 ? static_cast<size_t>(n) : 0);
  LockHolder h;
  const auto j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) return h;
  if (j.contains("pid") && j["pid"].is_number_integer()) h.pid = j["pid"].get<long>();
  auto str = [&](const char* k) { return j.contains(k) && j[k].is_string() ? j[k].get<std::string>() : std::string(); };
  h.host = str("host");
  h.command = str("command");
  h.start_time = str("start_time");
  return h;
}

bool same_file(int fd, const fs::path& p) {
  struct stat a {
  }, b{};
  return ::fstat(fd, &a) == 0 && ::stat(p.c_str(), &b) == 0 && a.st_dev == b.st_dev && a.st_ino == b.st_ino;
}

[[noreturn]] void busy(const fs::path& dir, const LockHolder& h) {
  throw Error("'" + dir.string() + "' is being written by another ccfr process (" + h.describe() +
              "); wait for it to end or stop it, then try again");
}

}  // namespace

std::string LockHolder::describe() const {
  std::string s = pid > 0 ? "pid " + std::to_string(pid) : std::string("pid unknown: no record written yet");
  if (!host.empty()) s += " on host " + host;
  if (!start_time.empty()) s += " since " + start_time;
  if (!command.empty()) s += ": " + command;
  return s;
}

DirLock::State::~State() {
  if (fd >= 0) {
    // Removed while still held, so that no other process can lock the file being removed.
    if (same_file(fd, file)) ::unlink(file.c_str());
    ::close(fd);
  }
  {
    std::lock_guard<std::mutex> g(registry_mutex());
    const auto it = registry().find(key);
    if (it != registry().end() && it->second.expired()) registry().erase(it);
  }
  // A directory made only to be locked (the run then failed to load) does not stay behind empty.
  std::error_code ec;
  if (created_dir && fs::is_empty(dir, ec)) fs::remove(dir, ec);
}

DirLock DirLock::acquire(const fs::path& dir, const std::string& command) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw Error("output directory '" + dir.string() + "' exists and is not a directory");
  bool created = false;
  if (!fs::exists(dir, ec)) {
    created = fs::create_directories(dir, ec);
    if (ec) throw Error("cannot create output directory '" + dir.string() + "': " + ec.message());
  }
  struct stat st {};
  if (::stat(dir.c_str(), &st) != 0) throw Error("cannot lock '" + dir.string() + "': " + std::strerror(errno));
  const std::pair<dev_t, ino_t> key{st.st_dev, st.st_ino};
  std::lock_guard<std::mutex> g(registry_mutex());
  if (auto held = registry()[key].lock()) {
    DirLock l;
    l.state_ = std::move(held);
    return l;
  }
  const fs::path file = dir / kLockFileName;
  for (int attempt = 0;; ++attempt) {
    const int fd = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (fd < 0)
      throw Error("cannot lock '" + dir.string() + "': cannot create '" + file.string() + "': " + std::strerror(errno));
    if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
      const int err = errno;
      const LockHolder h = read_record(fd);
      if (err == EWOULDBLOCK || err == EINTR) {
        ::close(fd);
        // `sweep status` probes a lock for an instant, and a new holder writes its record just
        // after locking: look again for a moment before calling the directory busy.
        if (attempt < 10) {
          std::this_thread::sleep_for(std::chrono::milliseconds(50));
          continue;
        }
        busy(dir, h);
      }
      if (err != ENOLCK && err != EOPNOTSUPP && err != EINVAL) {
        ::close(fd);
        throw Error("cannot lock '" + file.string() + "': " + std::strerror(err));
      }
      // A filesystem without flock: the record alone tells, for processes of this host.
      if (h.pid > 0 && h.pid != ::getpid() && h.host == host_name() && process_alive(h.pid)) {
        ::close(fd);
        busy(dir, h);
      }
    } else if (!same_file(fd, file)) {
      // The holder released (and removed) the file between our open and flock: that lock guards
      // nothing; open the path again.
      ::close(fd);
      if (attempt > 100) throw Error("cannot lock '" + file.string() + "': it keeps being replaced");
      continue;
    }
    const LockHolder old = read_record(fd);
    if (old.pid > 0)
      log::info("took over the stale lock of '{}' left by {} (that process no longer holds it)", dir.string(),
                old.describe());
    nlohmann::json rec = {{"pid", static_cast<long>(::getpid())},
                          {"host", host_name()},
                          {"command", command.empty() ? std::string("ccfr") : command},
                          {"start_time", utc_now()}};
    const std::string text = rec.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
    if (::ftruncate(fd, 0) != 0 || ::pwrite(fd, text.data(), text.size(), 0) != static_cast<ssize_t>(text.size())) {
      const int err = errno;
      ::close(fd);
      throw Error("cannot write '" + file.string() + "': " + std::strerror(err));
    }
    auto s = std::make_shared<State>();
    s->fd = fd;
    s->dir = dir;
    s->file = file;
    s->key = key;
    s->created_dir = created;
    registry()[key] = s;
    DirLock l;
    l.state_ = std::move(s);
    return l;
  }
}

std::optional<LockHolder> lock_holder(const fs::path& dir) {
  const fs::path file = dir / kLockFileName;
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) return std::nullopt;
  std::optional<LockHolder> out;
  if (::flock(fd, LOCK_SH | LOCK_NB) == 0) {
    ::flock(fd, LOCK_UN);
  } else if (errno == EWOULDBLOCK) {
    out = read_record(fd);
  } else {
    const LockHolder h = read_record(fd);
    if (h.host == host_name() && process_alive(h.pid)) out = h;
  }
  ::close(fd);
  return out;
}

bool dir_is_empty(const fs::path& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) return true;
  if (!fs::is_directory(dir, ec)) return false;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.path().filename() != kLockFileName) return false;
  return !ec;
}

}  // namespace ccfr::io
