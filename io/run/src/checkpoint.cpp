#include "ccfr/io/checkpoint.hpp"

#include <array>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

namespace {
constexpr char kMagic[8] = {'C', 'C', 'F', 'R', 'C', 'K', 'P', 'T'};
constexpr size_t kHeader = 8 + 4 + 8;  // magic, format, payload length
// The checkpoints are read back only by the build family that wrote them; a big-endian host
// would need byte swaps here, which ccfr does not target.
static_assert(sizeof(double) == 8 && sizeof(Vec3) == 24, "checkpoint layout assumes packed doubles");

const std::array<std::uint32_t, 256>& crc_table() {
  static const std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  return table;
}

class Writer {
 public:
  template <class T>
  void pod(const T& v) {
    out_.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  void str(const std::string& s) {
    pod<std::uint64_t>(s.size());
    out_ += s;
  }
  void doubles(const double* p, size_t n) {
    pod<std::uint64_t>(n);
    out_.append(reinterpret_cast<const char*>(p), n * sizeof(double));
  }
  void positions(const Positions& x) { doubles(x.empty() ? nullptr : x.front().data(), 3 * x.size()); }
  std::string& bytes() { return out_; }

 private:
  std::string out_;
};

class Reader {
 public:
  Reader(std::string_view in, const fs::path& file) : in_(in), file_(file) {}
  template <class T>
  T pod(const char* what) {
    need(sizeof(T), what);
    T v;
    std::memcpy(&v, in_.data() + at_, sizeof v);
    at_ += sizeof v;
    return v;
  }
  std::string str(const char* what) {
    const auto n = pod<std::uint64_t>(what);
    need(n, what);
    std::string s(in_.substr(at_, n));
    at_ += n;
    return s;
  }
  std::vector<double> doubles(const char* what) {
    const auto n = pod<std::uint64_t>(what);
    if (n > (in_.size() - at_) / sizeof(double)) fail(std::string(what) + " runs past the end of the payload");
    std::vector<double> v(n);
    if (n) std::memcpy(v.data(), in_.data() + at_, n * sizeof(double));
    at_ += n * sizeof(double);
    return v;
  }
  Positions positions(const char* what) {
    const std::vector<double> d = doubles(what);
    if (d.size() % 3)
      fail(std::string(what) + " has " + std::to_string(d.size()) + " coordinates, not a multiple of 3");
    Positions x(d.size() / 3);
    for (size_t i = 0; i < x.size(); ++i) x[i] = Vec3(d[3 * i], d[3 * i + 1], d[3 * i + 2]);
    return x;
  }
  bool done() const { return at_ == in_.size(); }
  [[noreturn]] void fail(const std::string& why) const {
    throw Error("checkpoint '" + file_.string() + "' is inconsistent: " + why);
  }

 private:
  void need(size_t n, const char* what) const {
    if (n > in_.size() - at_) fail(std::string(what) + " runs past the end of the payload");
  }
  std::string_view in_;
  size_t at_ = 0;
  const fs::path& file_;
};

std::uint64_t fnv(std::uint64_t h, const void* p, size_t n) {
  const auto* b = static_cast<const unsigned char*>(p);
  for (size_t i = 0; i < n; ++i) h = (h ^ b[i]) * 1099511628211ull;
  return h;
}
template <class V>
std::uint64_t fnv_vec(std::uint64_t h, const V& v) {
  const std::uint64_t n = v.size();
  h = fnv(h, &n, sizeof n);
  return v.empty() ? h : fnv(h, v.data(), v.size() * sizeof(v[0]));
}
}  // namespace

std::uint32_t crc32(std::string_view data) {
  const auto& t = crc_table();
  std::uint32_t c = 0xFFFFFFFFu;
  for (unsigned char b : data) c = t[(c ^ b) & 0xFFu] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

std::uint64_t scene_fingerprint(const Topology& topo, const SimState& initial) {
  std::uint64_t h = 14695981039346656037ull;
  for (const auto& o : topo.objects) {
    h = fnv(h, o.name.data(), o.name.size());
    const Index r[] = {
        static_cast<Index>(o.kind), o.vertex_begin, o.vertex_end, o.face_begin, o.face_end, o.tet_begin, o.tet_end};
    h = fnv(h, r, sizeof r);
  }
  h = fnv_vec(h, topo.faces);
  h = fnv_vec(h, topo.edges);
  h = fnv_vec(h, topo.tets);
  h = fnv_vec(h, initial.x);
  h = fnv_vec(h, initial.inv_mass);
  return h;
}

std::string encode_checkpoint(const Checkpoint& c) {
  Writer w;
  const auto& s = c.sim;
  w.str(c.ccfr_version);
  w.str(c.git_commit);
  w.str(c.resolved_config);
  w.str(c.scene_file.string());
  w.pod<std::uint64_t>(c.overrides.size());
  for (const auto& o : c.overrides) w.str(o);
  w.pod(c.scene_fingerprint);
  w.pod<std::int32_t>(s.frame);
  w.pod(s.time);
  w.positions(s.x);
  w.positions(s.v);
  w.positions(s.x_prev);
  w.doubles(s.solver_state.data(), s.solver_state.size());
  w.pod<std::uint8_t>(s.warned_violation);
  w.str(std::string(s.warned_capped.begin(), s.warned_capped.end()));
  w.doubles(c.audit_offsets.data(), c.audit_offsets.size());
  w.pod(c.violated_frames);
  w.pod(c.frames_written);
  const std::string& payload = w.bytes();

  Writer file;
  file.bytes().append(kMagic, sizeof kMagic);
  file.pod(kCheckpointFormat);
  file.pod<std::uint64_t>(payload.size());
  file.bytes() += payload;
  file.pod(crc32(file.bytes()));
  return std::move(file.bytes());
}

Checkpoint decode_checkpoint(std::string_view bytes, const fs::path& file) {
  const std::string name = "checkpoint '" + file.string() + "'";
  if (bytes.size() < sizeof kMagic || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0)
    throw Error(name + " is not a ccfr checkpoint (no CCFRCKPT header)");
  if (bytes.size() < kHeader)
    throw Error(name + " is truncated: " + std::to_string(bytes.size()) + " bytes, no header");
  std::uint32_t format = 0;
  std::uint64_t length = 0;
  std::memcpy(&format, bytes.data() + 8, 4);
  std::memcpy(&length, bytes.data() + 12, 8);
  if (format != kCheckpointFormat)
    throw Error(name + " has format version " + std::to_string(format) + "; this ccfr reads version " +
                std::to_string(kCheckpointFormat) + " (rerun from the start)");
  const std::uint64_t expected = kHeader + length + 4;
  if (length > bytes.size() || bytes.size() != expected)
    throw Error(name + " is truncated or has trailing bytes: " + std::to_string(bytes.size()) +
                " bytes, its header says " + std::to_string(expected));
  std::uint32_t stored = 0;
  std::memcpy(&stored, bytes.data() + kHeader + length, 4);
  const std::uint32_t actual = crc32(bytes.substr(0, kHeader + length));
  if (stored != actual) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "checksum mismatch (CRC-32 stored %08x, computed %08x)", stored, actual);
    throw Error(name + " is corrupted: " + buf);
  }
  Reader r(bytes.substr(kHeader, length), file);
  Checkpoint c;
  auto& s = c.sim;
  c.ccfr_version = r.str("ccfr version");
  c.git_commit = r.str("git commit");
  c.resolved_config = r.str("resolved configuration");
  c.scene_file = r.str("scene file");
  const auto n_over = r.pod<std::uint64_t>("override count");
  if (n_over > length) r.fail("override count " + std::to_string(n_over));
  for (std::uint64_t i = 0; i < n_over; ++i) c.overrides.push_back(r.str("override"));
  c.scene_fingerprint = r.pod<std::uint64_t>("scene fingerprint");
  s.frame = r.pod<std::int32_t>("frame");
  s.time = r.pod<double>("time");
  s.x = r.positions("positions");
  s.v = r.positions("velocities");
  s.x_prev = r.positions("previous positions");
  s.solver_state = r.doubles("solver state");
  s.warned_violation = r.pod<std::uint8_t>("warning flags") != 0;
  const std::string capped = r.str("warning flags");
  s.warned_capped.assign(capped.begin(), capped.end());
  c.audit_offsets = r.doubles("audit state");
  c.violated_frames = r.pod<std::int64_t>("violated frames");
  c.frames_written = r.pod<std::int32_t>("frames written");
  if (!r.done()) r.fail("bytes left after the last field");
  if (s.frame < 0) r.fail("frame " + std::to_string(s.frame));
  if (s.v.size() != s.x.size() || s.x_prev.size() != s.x.size())
    r.fail(std::to_string(s.x.size()) + " positions but " + std::to_string(s.v.size()) + " velocities");
  return c;
}

fs::path checkpoint_path(const fs::path& run_dir, int frame) {
  char name[40];
  std::snprintf(name, sizeof name, "checkpoint_%05d.ccfr", frame);
  return run_dir / "checkpoints" / name;
}

fs::path write_checkpoint(const fs::path& run_dir, const Checkpoint& c) {
  const fs::path p = checkpoint_path(run_dir, c.sim.frame);
  std::error_code ec;
  fs::create_directories(p.parent_path(), ec);
  if (ec) throw Error("cannot create '" + p.parent_path().string() + "': " + ec.message());
  write_file_atomic(p, encode_checkpoint(c));
  // Only the newest is kept: it supersedes the others, and a resume starts from it.
  for (const auto& e : fs::directory_iterator(p.parent_path(), ec)) {
    const std::string n = e.path().filename().string();
    if (e.path() != p && n.rfind("checkpoint_", 0) == 0 && e.path().extension() == ".ccfr") fs::remove(e.path(), ec);
  }
  return p;
}

std::optional<fs::path> latest_checkpoint(const fs::path& run_dir) {
  std::optional<fs::path> best;
  long best_frame = -1;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(run_dir / "checkpoints", ec)) {
    const std::string n = e.path().filename().string();
    if (n.size() != 21 || n.rfind("checkpoint_", 0) != 0 || e.path().extension() != ".ccfr") continue;
    const std::string digits = n.substr(11, 5);
    if (digits.find_first_not_of("0123456789") != std::string::npos) continue;
    const long f = std::stol(digits);
    if (f > best_frame) best_frame = f, best = e.path();
  }
  return best;
}

Checkpoint read_checkpoint(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error("cannot read checkpoint '" + file.string() + "': " + std::strerror(errno));
  std::stringstream ss;
  ss << in.rdbuf();
  return decode_checkpoint(ss.str(), file);
}

namespace {
using Json = nlohmann::ordered_json;
std::string first_difference(const Json& a, const Json& b, const std::string& path) {
  if (a.is_object() && b.is_object()) {
    for (const auto& [k, v] : a.items()) {
      const std::string p = path.empty() ? k : path + "." + k;
      if (!b.contains(k)) return p + ": only in the checkpoint";
      if (std::string d = first_difference(v, b[k], p); !d.empty()) return d;
    }
    for (const auto& [k, v] : b.items())
      if (!a.contains(k)) return (path.empty() ? k : path + "." + k) + ": not in the checkpoint";
    return {};
  }
  if (a.is_array() && b.is_array() && a.size() == b.size()) {
    for (size_t i = 0; i < a.size(); ++i)
      if (std::string d = first_difference(a[i], b[i], path + "[" + std::to_string(i) + "]"); !d.empty()) return d;
    return {};
  }
  if (a == b) return {};
  return (path.empty() ? std::string("(root)") : path) + ": " + a.dump() + " in the checkpoint, " + b.dump() + " now";
}
}  // namespace

std::string json_difference(const std::string& a, const std::string& b) {
  const Json ja = Json::parse(a, nullptr, false), jb = Json::parse(b, nullptr, false);
  if (ja.is_discarded() || jb.is_discarded()) return a == b ? std::string() : "(configuration text differs)";
  return first_difference(ja, jb, "");
}

}  // namespace ccfr::io
