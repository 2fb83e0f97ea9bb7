#include "ccfr/io/output.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <nlohmann/json.hpp>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/process.hpp"
#include "ccfr/io/obj.hpp"

namespace ccfr::io {

namespace detail {
extern const char* const kGitCommit;  // build/generated/git_commit.cpp (cmake/GitCommit.cmake)
}

namespace fs = std::filesystem;

std::string version() { return CCFR_VERSION; }
std::string git_commit() { return detail::kGitCommit; }

namespace {
using Json = nlohmann::ordered_json;

[[noreturn]] void io_error(const std::string& what, const fs::path& p, int err) {
  throw Error(what + " '" + p.string() + "': " + std::strerror(err));
}

// DIR without a trailing separator, so that its siblings can be named.
fs::path normalized(const fs::path& dir) {
  fs::path p = fs::absolute(dir).lexically_normal();
  if (!p.has_filename() && p.has_parent_path()) p = p.parent_path();
  return p;
}

// frames/frame_NNNNN.obj files with their frame numbers.
std::vector<std::pair<long, fs::path>> list_frame_files(const fs::path& frames) {
  std::vector<std::pair<long, fs::path>> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(frames, ec)) {
    const std::string n = e.path().filename().string();
    if (n.size() < 11 || n.rfind("frame_", 0) != 0 || e.path().extension() != ".obj") continue;
    const std::string digits = n.substr(6, n.size() - 10);
    if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos) continue;
    out.emplace_back(std::stol(digits), e.path());
  }
  return out;
}

bool is_temp_name(const std::string& name) { return name.find(".tmp") != std::string::npos; }

// Temporary files of a crashed run: run.json.tmpPID, frames/frame_NNNNN.obj.tmpPID,
// checkpoints/checkpoint_NNNNN.ccfr.tmpPID (a SIGKILL during a checkpoint's write).
void remove_stale_temporaries(const fs::path& dir) {
  std::error_code ec;
  for (const fs::path& d : {dir, dir / "frames", dir / "checkpoints"}) {
    if (!fs::is_directory(d, ec)) continue;
    for (const auto& e : fs::directory_iterator(d, ec)) {
      const std::string n = e.path().filename().string();
      if ((n.rfind("frame_", 0) == 0 || n.rfind("run.json", 0) == 0 || n.rfind("checkpoint_", 0) == 0) &&
          is_temp_name(n) && e.is_regular_file(ec))
        fs::remove(e.path(), ec);
    }
  }
}

// The previous run's entries are all out of DIR (in DIR.ccfr-old): a commit killed after this
// point is finished by the next writer, one killed before it is undone (recover_commit).
constexpr const char* kCommitMarker = ".ccfr-commit";

fs::path sibling(const fs::path& dir, const char* suffix) {
  const fs::path base = normalized(dir);
  return base.parent_path() / (base.filename().string() + suffix);
}

// The entries of `dir` that are ccfr's (is_run_entry) and not its lock, run.json first.
std::vector<std::string> own_entries(const fs::path& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string n = e.path().filename().string();
    if (is_run_entry(n) && n != kLockFileName) out.push_back(n);
  }
  std::sort(out.begin(), out.end(), [](const std::string& a, const std::string& b) {
    return (a == "run.json") != (b == "run.json") ? a == "run.json" : a < b;
  });
  return out;
}

// A directory DIR.ccfr-new / DIR.ccfr-old left by a killed run: nothing in it but run entries.
bool is_leftover_run(const fs::path& d) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(d, ec)) {
    const std::string n = e.path().filename().string();
    if (!is_run_entry(n) && n != kCommitMarker) return false;
  }
  return !ec;
}

int rename_error(const fs::path& from, const fs::path& to) {
  return ::rename(from.c_str(), to.c_str()) == 0 ? 0 : errno;
}

// Finishes or undoes the replacement of a run that a killed ccfr left half done, and removes a
// staged run it never put in place (DIR.ccfr-new). Called with DIR's lock held.
void recover_commit(const fs::path& dir) {
  const fs::path staged = sibling(dir, ".ccfr-new"), old = sibling(dir, ".ccfr-old");
  std::error_code ec;
  for (const fs::path& p : {staged, old})
    if (fs::exists(p, ec) && (!fs::is_directory(p, ec) || !is_leftover_run(p)))
      throw Error("'" + p.string() + "' is in the way of the run in '" + dir.string() +
                  "' and does not hold ccfr's run files only; move it away");
  if (fs::exists(old, ec)) {
    if (fs::exists(old / kCommitMarker, ec) && fs::exists(staged, ec)) {
      // Killed while moving the new run in: the previous one is all out, finish moving.
      std::vector<std::string> names = own_entries(staged);
      std::rotate(names.begin(), names.begin() + (names.empty() || names[0] != "run.json" ? 0 : 1), names.end());
      for (const auto& n : names)
        if (const int err = rename_error(staged / n, dir / n))
          throw Error("cannot finish replacing the run in '" + dir.string() + "' that a killed ccfr left half done: " +
                      "cannot move '" + (staged / n).string() + "' into it: " + std::strerror(err));
      log::warn("finished replacing the run in '{}' that a killed ccfr left half done", dir.string());
    } else if (!fs::exists(old / kCommitMarker, ec)) {
      // Killed while moving the previous run out: put it back.
      for (const auto& n : own_entries(old))
        if (!fs::exists(dir / n, ec))
          if (const int err = rename_error(old / n, dir / n))
            throw Error("cannot restore '" + (dir / n).string() + "' from '" + (old / n).string() +
                        "' (a killed ccfr left it there): " + std::strerror(err));
      log::warn("restored the previous run in '{}' that a killed ccfr had begun to replace", dir.string());
    }
    fs::remove_all(old, ec);
    if (ec) throw Error("cannot remove '" + old.string() + "' (left by a killed ccfr): " + ec.message());
  }
  if (fs::exists(staged, ec)) {
    fs::remove_all(staged, ec);  // a run killed before it replaced its predecessor
    if (ec) throw Error("cannot remove '" + staged.string() + "' (left by a killed ccfr): " + ec.message());
  }
}

// Every directory under `p` (p included) must be writable for its entries to be moved and removed.
void check_replaceable(const fs::path& run, const fs::path& p) {
  std::error_code ec;
  if (fs::is_symlink(p, ec) || !fs::is_directory(p, ec)) return;
  if (::access(p.c_str(), W_OK | X_OK) != 0) {
    const int err = errno;
    throw Error("cannot rerun into '" + run.string() + "': the previous run's '" + p.string() + "' is not writable (" +
                std::strerror(err) + "), so it could not be replaced; make it writable (chmod -R u+w '" + p.string() +
                "') or choose another --out. Nothing was changed");
  }
  for (const auto& e : fs::directory_iterator(p, ec)) check_replaceable(run, e.path());
}

void create_dirs(const fs::path& d) {
  std::error_code ec;
  fs::create_directories(d, ec);
  if (ec) throw Error("cannot create output directory '" + d.string() + "': " + ec.message());
}

// Writes all of `data` to fd; on failure returns the errno (0 on success).
int write_all(int fd, const std::string& data) {
  const char* p = data.data();
  size_t left = data.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return errno;
    if (n == 0) return EIO;
    p += n;
    left -= static_cast<size_t>(n);
  }
  return 0;
}
}  // namespace

bool is_run_entry(const std::string& n) {
  static const char* const kNames[] = {"run.json", "stats.csv", "frames",  "checkpoints", "audit.json",
                                       "render",   "vtk",       "blender", "usd",         "stats.png"};
  if (n == kLockFileName) return true;
  auto is = [&](const std::string& k) { return n == k || (n.rfind(k + ".tmp", 0) == 0 && n.size() > k.size() + 4); };
  for (const char* k : kNames)
    if (is(k)) return true;
  // A frame writer added to the registry writes into the folder named by its key (docs/extending.md).
  for (const auto& k : frame_writer_names())
    if (is(k)) return true;
  return false;
}

bool is_ccfr_run(const fs::path& dir) {
  std::ifstream in(dir / "run.json");
  if (!in) return false;
  const Json j = Json::parse(in, nullptr, /*allow_exceptions=*/false);
  return j.is_object() && j.contains("ccfr") && j["ccfr"].is_object() && j["ccfr"].contains("version");
}

std::string previous_run_note(const fs::path& dir) {
  std::error_code ec;
  const fs::path old = sibling(dir, ".ccfr-old");
  if (!fs::exists(old / "run.json", ec)) return "";
  return "; its earlier run is in '" + old.string() + "' (a rerun was killed while it replaced it)";
}

std::string run_json_problem(const fs::path& dir) {
  const fs::path rj = dir / "run.json";
  std::error_code ec;
  const fs::file_status st = fs::status(rj, ec);
  if (st.type() == fs::file_type::not_found) return "no run.json" + previous_run_note(dir);
  if (ec) return "run.json is unreadable: " + ec.message();
  if (st.type() != fs::file_type::regular) return "run.json is not a regular file";
  std::ifstream in(rj);
  if (!in) return "run.json is unreadable: cannot open it";
  const Json j = Json::parse(in, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded())
    return "run.json is unreadable: not valid JSON (truncated or damaged; " + std::to_string(fs::file_size(rj, ec)) +
           " bytes)";
  if (!is_ccfr_run(dir)) return "run.json was not written by ccfr (no \"ccfr\": {\"version\": ...})";
  return "";
}

RunWriter::RunWriter(fs::path dir, const Topology& topo, std::string resolved_config_json, RunMeta meta, bool force)
    : final_(std::move(dir)),
      topo_(topo),
      config_json_(std::move(resolved_config_json)),
      meta_(std::move(meta)),
      start_time_(utc_now()) {
  lock_ = DirLock::acquire(final_, meta_.command_line);
  recover_commit(final_);
  std::error_code ec;
  if (dir_is_empty(final_)) {
    dir_ = final_;
  } else if (is_ccfr_run(final_)) {
    // A rerun: the previous run stays whole until the new one has a simulated frame to show, and
    // then only ccfr's own entries are replaced.
    remove_stale_temporaries(final_);
    if (::access(final_.c_str(), W_OK | X_OK) != 0)
      throw Error("cannot rerun into '" + final_.string() + "': it is not writable (" + std::strerror(errno) + ")");
    for (const auto& n : own_entries(final_)) check_replaceable(final_, final_ / n);
    staging_ = sibling(final_, ".ccfr-new");
    staged_ = true;
    dir_ = staging_;
  } else if (force) {
    // --force: ccfr's files go in beside the user's; an entry of ccfr's name that ccfr did not
    // write (there is no run here) is the user's, and is not overwritten.
    remove_stale_temporaries(final_);
    std::string clash;
    for (const auto& n : own_entries(final_))
      if (n.find(".tmp") == std::string::npos) clash += (clash.empty() ? "'" : ", '") + (final_ / n).string() + "'";
    if (!clash.empty())
      throw Error("output directory '" + final_.string() + "' is not a ccfr run, and " + clash +
                  " would be overwritten by the run's own files; move them away or choose another --out");
    dir_ = final_;
  } else {
    throw Error("output directory '" + final_.string() + "' is not empty and is not a ccfr run (" +
                run_json_problem(final_) +
                "); choose another --out or pass --force (to write the run's files beside the ones there)");
  }
  create_dirs(dir_ / "frames");
  remove_stale_temporaries(dir_);
  make_sinks();
}

void RunWriter::make_sinks() {
  // A writer's parameters are its section of the resolved configuration, `output.<format>`
  // (checked by the scene schema); keys absent there take their defaults.
  const Json config = Json::parse(config_json_, nullptr, /*allow_exceptions=*/false);
  const Json* output =
      config.is_object() && config.contains("output") && config["output"].is_object() ? &config["output"] : nullptr;
  for (const std::string& f : meta_.formats) {
    std::vector<std::string> others;
    for (const std::string& g : meta_.formats)
      if (g != f) others.push_back(g);
    ParamValues params;
    const auto& entry = frame_writers().at(f);
    if (output && output->contains(f) && (*output)[f].is_object())
      for (const ParamSpec& spec : entry.params) {
        const Json& section = (*output)[f];
        if (!section.contains(spec.key)) continue;
        const Json& v = section[spec.key];
        const bool fits = spec.type == ParamType::boolean   ? v.is_boolean()
                          : spec.type == ParamType::integer ? v.is_number_integer()
                          : spec.type == ParamType::number  ? v.is_number()
                                                            : v.is_string();
        if (!fits)
          throw Error("config.output." + f + "." + spec.key + ": " + v.dump() + " is not of the parameter's type");
        if (spec.type == ParamType::boolean) params.set(spec.key, v.get<bool>());
        if (spec.type == ParamType::integer) params.set(spec.key, v.get<long long>());
        if (spec.type == ParamType::number) params.set(spec.key, v.get<double>());
        if (spec.type == ParamType::choice) params.set(spec.key, v.get<std::string>());
      }
    sinks_.push_back(make_frame_sink(
        f, FrameSinkContext{topo_, meta_.fps, meta_.every, std::move(others), true, meta_.scene_fingerprint}, params));
  }
}

bool RunWriter::wants_fields() const {
  for (const auto& s : sinks_)
    if (s->wants_fields()) return true;
  return false;
}

RunWriter::RunWriter(fs::path dir, const Topology& topo, std::string resolved_config_json, RunMeta meta,
                     ResumeAt resume)
    : dir_(dir),
      final_(std::move(dir)),
      topo_(topo),
      config_json_(std::move(resolved_config_json)),
      meta_(std::move(meta)),
      resume_frame_(resume.frame) {
  lock_ = DirLock::acquire(final_, meta_.command_line);
  recover_commit(final_);
  std::ifstream in(final_ / "run.json");
  const Json old = in ? Json::parse(in, nullptr, /*allow_exceptions=*/false) : Json();
  if (!is_ccfr_run(final_) || !old.is_object())
    throw Error("cannot resume '" + final_.string() + "': no run.json written by ccfr in it");
  start_time_ =
      old.contains("start_time") && old["start_time"].is_string() ? old["start_time"].get<std::string>() : utc_now();
  Json resumed = old.contains("resumed") && old["resumed"].is_array() ? old["resumed"] : Json::array();
  resumed.push_back({{"after_frame", resume.frame}, {"time", utc_now()}});
  resumed_json_ = resumed.dump();
  remove_stale_temporaries(final_);

  // stats.csv: the header and exactly the rows of frames 1..F, then whatever the run wrote after
  // its checkpoint, which is cut off and computed again.
  const fs::path stats = final_ / "stats.csv";
  std::ifstream sin(stats, std::ios::binary);
  if (!sin) throw Error("cannot resume '" + final_.string() + "': cannot read '" + stats.string() + "'");
  std::string line;
  long long size = 0;
  int rows = 0;
  if (!std::getline(sin, line) || line != stats_header() || sin.eof())
    throw Error("cannot resume: '" + stats.string() + "' does not start with the stats.csv header of this ccfr");
  size = static_cast<long long>(line.size()) + 1;
  static_assert(stats_column("frame") == 0, "the rows are matched to frames by their first cell");
  while (rows < resume.frame && std::getline(sin, line) && !sin.eof()) {
    if (line.rfind(std::to_string(rows + 1) + ",", 0) != 0)
      throw Error("cannot resume: row " + std::to_string(rows + 1) + " of '" + stats.string() + "' is not frame " +
                  std::to_string(rows + 1));
    size += static_cast<long long>(line.size()) + 1;
    ++rows;
  }
  if (rows < resume.frame)
    throw Error("cannot resume: '" + stats.string() + "' has " + std::to_string(rows) +
                " whole rows, the checkpoint is at frame " + std::to_string(resume.frame));
  resume_stats_size_ = size;

  // The frames written before the checkpoint (frame 0, then every output.every-th; the last frame
  // of the run comes after it). The other formats continue from them (FrameSink::resume): per-frame
  // files are kept, PC2 caches cut back to them, USDA and the VTU collection rebuilt with them.
  std::vector<int> before;
  for (int f = 0; meta_.frames && f <= resume.frame; f += std::max(1, meta_.every)) before.push_back(f);
  make_sinks();
  std::vector<FrameSink*> sinks;
  for (const auto& s : sinks_) sinks.push_back(s.get());
  resume_frame_sinks(sinks, final_, resume.frame, before, meta_.fps);
  create_dirs(final_ / "frames");
  // frames_written: the OBJ frames left on disk (the obj sink removed those after the checkpoint),
  // else the frames the other formats hold.
  if (std::find(meta_.formats.begin(), meta_.formats.end(), "obj") != meta_.formats.end()) {
    for (const auto& p : list_frame_files(final_ / "frames"))
      if (p.first <= resume.frame) ++frames_written_;
  } else {
    frames_written_ = static_cast<int>(before.size());
  }
}

RunWriter::~RunWriter() {
  if (stats_fd_ >= 0) ::close(stats_fd_);
  // Left by an exception before finish(): a staged run never replaces the previous one.
  if (staged_ && !discarded_ && dir_ == staging_) {
    std::error_code ec;
    fs::remove_all(staging_, ec);
    if (ec)
      log::error("cannot remove the unfinished run in '{}': {}; the previous run in '{}' is kept, remove it yourself",
                 staging_.string(), ec.message(), final_.string());
  }
}

void RunWriter::start() {
  write_run_json("running", false);
  const fs::path p = dir_ / "stats.csv";
  if (resume_frame_ >= 0) {
    stats_fd_ = ::open(p.c_str(), O_WRONLY | O_CLOEXEC);
    if (stats_fd_ < 0) io_error("cannot write", p, errno);
    if (::ftruncate(stats_fd_, static_cast<off_t>(resume_stats_size_)) != 0 ||
        ::lseek(stats_fd_, static_cast<off_t>(resume_stats_size_), SEEK_SET) < 0)
      io_error("cannot write", p, errno);
    stats_size_ = resume_stats_size_;
    return;
  }
  stats_fd_ = ::open(p.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (stats_fd_ < 0) io_error("cannot write", p, errno);
  stats_size_ = 0;
  write_stats_line(stats_header());
}

void RunWriter::write_frame(int frame, const Positions& x, const VertexFields& fields) {
  const double time = meta_.fps > 0 ? frame / meta_.fps : 0.0;
  for (auto& s : sinks_) s->write(dir_, frame, time, x, fields);
  ++frames_written_;
  write_run_json("running", false);  // a killed run still tells how many frames are on disk
}

void RunWriter::write_stats(const FrameStats& s) {
  write_stats_line(stats_row(s));
  if (staged_ && dir_ == staging_) commit();
}

void RunWriter::write_stats_line(const std::string& row) {
  const std::string line = row + '\n';
  if (const int err = write_all(stats_fd_, line)) {
    // A short write before the failure would leave half a row: cut the file back to whole rows.
    if (::ftruncate(stats_fd_, static_cast<off_t>(stats_size_)) == 0) ::lseek(stats_fd_, stats_size_, SEEK_SET);
    io_error("cannot write", dir_ / "stats.csv", err);
  }
  stats_size_ += static_cast<long long>(line.size());
}

void RunWriter::commit() {
  // The previous run's own entries out to DIR.ccfr-old (run.json first: DIR is no run meanwhile),
  // then the new run's in (run.json last); every other entry of DIR stays in place. A failure puts
  // back what was moved; a kill half-way is finished or undone by the next writer (recover_commit).
  const fs::path old = sibling(final_, ".ccfr-old");
  std::error_code ec;
  if (!fs::create_directory(old, ec))
    throw Error("cannot create '" + old.string() + "' to replace the previous run in '" + final_.string() +
                "': " + (ec ? ec.message() : std::string("it exists")));
  std::vector<std::string> out_names, in_names;
  auto undo = [&](const std::string& why) {
    std::string stuck;
    for (auto it = in_names.rbegin(); it != in_names.rend(); ++it)
      if (rename_error(final_ / *it, staging_ / *it)) stuck += " '" + (final_ / *it).string() + "'";
    fs::remove(old / kCommitMarker, ec);
    for (auto it = out_names.rbegin(); it != out_names.rend(); ++it)
      if (rename_error(old / *it, final_ / *it)) stuck += " '" + (old / *it).string() + "'";
    if (stuck.empty()) {
      fs::remove(old, ec);
      throw Error(why + "; the previous run in '" + final_.string() + "' is kept");
    }
    throw Error(why + "; putting the previous run back failed too: it is in '" + old.string() + "', this run in '" +
                staging_.string() + "', and these could not be moved back:" + stuck);
  };
  for (const auto& n : own_entries(final_)) {
    if (const int err = rename_error(final_ / n, old / n))
      undo("cannot move the previous run's '" + (final_ / n).string() + "' aside to '" + old.string() +
           "': " + std::strerror(err));
    out_names.push_back(n);
  }
  if (const int fd = ::open((old / kCommitMarker).c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0644); fd >= 0)
    ::close(fd);
  else
    undo("cannot write '" + (old / kCommitMarker).string() + "': " + std::strerror(errno));
  std::vector<std::string> names = own_entries(staging_);
  std::rotate(names.begin(), names.begin() + (names.empty() || names[0] != "run.json" ? 0 : 1), names.end());
  for (const auto& n : names) {
    if (const int err = rename_error(staging_ / n, final_ / n))
      undo("cannot move '" + (staging_ / n).string() + "' into '" + final_.string() + "': " + std::strerror(err));
    in_names.push_back(n);
  }
  dir_ = final_;
  fs::remove(staging_, ec);
  fs::remove_all(old, ec);
  if (ec) {
    cleanup_error_ = "the run is in '" + final_.string() + "', but the previous run's files could not be removed (" +
                     ec.message() + "): they are in '" + old.string() + "'; remove it yourself";
    log::error("{}", cleanup_error_);
  }
}

void RunWriter::discard() {
  if (stats_fd_ >= 0) ::close(stats_fd_);
  stats_fd_ = -1;
  std::error_code ec;
  fs::remove_all(staging_, ec);
  discarded_ = true;
  if (ec) {
    cleanup_error_ = "the unfinished run in '" + staging_.string() + "' could not be removed (" + ec.message() +
                     "); the previous run in '" + final_.string() + "' is kept; remove it yourself";
    log::error("{}", cleanup_error_);
  }
}

void RunWriter::finish(const std::string& status) {
  if (staged_ && dir_ == staging_) {
    if (status != "completed") return discard();
    commit();
  }
  for (auto& s : sinks_) s->finish(dir_);
  if (stats_fd_ >= 0) {
    const int rc = ::close(stats_fd_);
    stats_fd_ = -1;
    if (rc != 0) io_error("cannot write", dir_ / "stats.csv", errno);
  }
  write_run_json(status, true);
}

void RunWriter::write_run_json(const std::string& status, bool finished) {
  RunProgress p;
  p.start_time = start_time_;
  if (finished) p.end_time = utc_now();
  p.status = status;
  p.frames_written = frames_written_;
  p.resumed_json = resumed_json_;
  p.stop_json = stop_json_;
  p.vertices = topo_.num_vertices();
  if (meta_.memory_estimate > 0) p.peak_resident_bytes = peak_resident_bytes();
  write_file_atomic(dir_ / "run.json", format_run_json(meta_, p, config_json_));
}

}  // namespace ccfr::io
