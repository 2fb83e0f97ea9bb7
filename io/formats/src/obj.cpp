#include "ccfr/io/obj.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <system_error>

#include "ccfr/core/error.hpp"
#include "ccfr/io/user_file.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

// The first line of a frame written by a run: `# ccfr frame scene_fingerprint=<16 hex digits>`.
constexpr const char* kFingerprintTag = "scene_fingerprint=";

void write_file_atomic(const fs::path& path, const std::string& content) {
  // Temporary name: "<name>.tmp<pid>" in the same folder (RunWriter removes stale ones of a crashed
  // run). On any failure the temporary file is removed, so a full disk leaves nothing behind.
  const fs::path tmp = path.string() + ".tmp" + std::to_string(::getpid());
  auto fail = [&](int err) {
    ::unlink(tmp.c_str());
    throw Error("cannot write '" + path.string() + "': " + std::strerror(err));
  };
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw Error("cannot write '" + path.string() + "': " + std::strerror(errno));
  const char* p = content.data();
  size_t left = content.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : EIO;
      ::close(fd);
      fail(err);
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  // The data reaches the disk before the rename: after a power loss the name holds either the
  // old content or the whole new one, never a renamed empty or partial file (ext4, xfs, btrfs).
  if (::fsync(fd) != 0 && errno != EINVAL) {  // EINVAL: a file system without fsync (a pipe, some FUSE)
    const int err = errno;
    ::close(fd);
    fail(err);
  }
  if (::close(fd) != 0) fail(errno);  // delayed allocation can report ENOSPC only here
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw Error("cannot rename '" + tmp.string() + "' to '" + path.string() + "': " + std::strerror(err));
  }
  // And the rename itself: the directory entry is durable once its folder is synced.
  const fs::path parent = path.has_parent_path() ? path.parent_path() : fs::path(".");
  if (const int dfd = ::open(parent.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC); dfd >= 0) {
    const int rc = ::fsync(dfd), err = errno;
    ::close(dfd);
    if (rc != 0 && err != EINVAL)
      throw Error("cannot sync the folder of '" + path.string() + "': " + std::strerror(err));
  }
}

namespace {
/// Appends " " and x as printf's "%.17g" writes it (to_chars with a precision is specified to
/// match printf), at about a third of snprintf's cost: a 40,000-vertex frame spent 3 % of a
/// soft-wire frame's work in printf.
void append_coordinate(std::string& s, double x) {
  char buf[32];
  buf[0] = ' ';
  const auto r = std::to_chars(buf + 1, buf + sizeof buf, x, std::chars_format::general, 17);
  s.append(buf, r.ptr);
}
void append_index(std::string& s, Index i) {
  char buf[16];
  buf[0] = ' ';
  const auto r = std::to_chars(buf + 1, buf + sizeof buf, i);
  s.append(buf, r.ptr);
}
}  // namespace

void write_frame_obj(const fs::path& path, const Topology& topo, const Positions& x, std::uint64_t scene_fingerprint) {
  std::string s;
  s.reserve(x.size() * 40 + topo.faces.size() * 24);
  char buf[128];
  s += "# ccfr frame";
  if (scene_fingerprint != 0) {
    std::snprintf(buf, sizeof buf, " %s%016llx", kFingerprintTag, static_cast<unsigned long long>(scene_fingerprint));
    s += buf;
  }
  s += "\n";
  for (const auto& o : topo.objects) {
    s += "o " + o.name + "\n";
    for (Index v = o.vertex_begin; v < o.vertex_end; ++v) {
      s += 'v';
      for (int k = 0; k < 3; ++k) append_coordinate(s, x[v][k]);
      s += '\n';
    }
    for (Index f = o.face_begin; f < o.face_end; ++f) {
      s += 'f';
      for (int k = 0; k < 3; ++k) append_index(s, topo.faces[f][k] + 1);
      s += '\n';
    }
    for (Index l = o.polyline_begin; l < o.polyline_end; ++l) {
      s += 'l';
      for (Index v : topo.polylines.row(l)) append_index(s, v + 1);
      s += '\n';
    }
    if (o.kind == ObjectKind::particles && o.num_vertices() > 0) {
      s += 'p';
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v) append_index(s, v + 1);
      s += '\n';
    }
  }
  write_file_atomic(path, s);
}

namespace {
[[noreturn]] void fail(const fs::path& p, int line, const std::string& msg) {
  // `msg` may quote the file's bytes: escape sequences in them must not reach the terminal.
  throw Error(printable(p.string()) + ":" + std::to_string(line) + ": " + printable(msg));
}

// Statements without geometry: texture / normal / parameter-space vertices, smoothing, materials
// and display attributes.
bool ignored_statement(const std::string& tag) {
  static const char* const kIgnored[] = {"vt",       "vn",       "vp",         "s",         "usemtl",
                                         "mtllib",   "usemap",   "maplib",     "lod",       "bevel",
                                         "c_interp", "d_interp", "shadow_obj", "trace_obj", "mg"};
  for (const char* t : kIgnored)
    if (tag == t) return true;
  return false;
}

Index parse_index(const std::string& tok, Index nv, const fs::path& p, int line) {
  // Accept "i", "i/t", "i/t/n", "i//n"; negative indices are relative to the end.
  const std::string head = tok.substr(0, tok.find('/'));
  char* end = nullptr;
  const long v = std::strtol(head.c_str(), &end, 10);
  if (head.empty() || *end != '\0' || v == 0) fail(p, line, "bad vertex index '" + tok + "'");
  const long idx = v > 0 ? v - 1 : nv + v;
  if (idx < 0 || idx >= nv)
    fail(p, line, "vertex index " + tok + " out of range (" + std::to_string(nv) + " vertices so far)");
  return static_cast<Index>(idx);
}

template <class Sink>
void parse_obj(const fs::path& path, Sink&& sink, std::string* first_line = nullptr) {
  check_user_file(path, "mesh file", kMaxMeshFileBytes);  // no FIFO, device or endless file
  std::ifstream in(path);
  if (!in) throw Error("cannot open '" + path.string() + "'");
  std::string line, tag, tok;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    if (lineno == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // a UTF-8 BOM, as YAML allows
    if (!line.empty() && line.back() == '\r') line.pop_back();                // CRLF
    if (line.find('\r') != std::string::npos)
      fail(path, lineno,
           "carriage return inside a line (old Mac line endings?): the statements after it would be dropped; "
           "convert the file to \\n line endings");
    if (lineno == 1 && first_line) *first_line = line;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    if (!(ls >> tag) || tag[0] == '#') continue;  // blank, or an indented comment
    sink(tag, ls, lineno);
  }
}
}  // namespace

Frame read_frame_obj(const fs::path& path) {
  Frame fr;
  std::string first_line;
  auto current = [&]() -> FrameObject& {
    if (fr.objects.empty()) fr.objects.push_back({"default"});
    return fr.objects.back();
  };
  parse_obj(
      path,
      [&](const std::string& tag, std::istringstream& ls, int ln) {
        const Index nv = static_cast<Index>(fr.v.size());
        std::string tok;
        if (tag == "o" || tag == "g") {
          std::string name;
          std::getline(ls >> std::ws, name);
          FrameObject o;
          o.name = name;
          o.vertex_begin = o.vertex_end = nv;
          o.face_begin = o.face_end = static_cast<Index>(fr.faces.size());
          o.line_begin = o.line_end = static_cast<Index>(fr.lines.size());
          o.point_begin = o.point_end = static_cast<Index>(fr.points.size());
          o.line = ln;
          fr.objects.push_back(o);
        } else if (tag == "v") {
          double c[3];
          for (double& ci : c) {
            if (!(ls >> tok)) fail(path, ln, "vertex needs 3 coordinates");
            char* end = nullptr;
            ci = std::strtod(tok.c_str(), &end);
            if (*end != '\0') fail(path, ln, "bad coordinate '" + tok + "'");
            const std::string vertex = "vertex " + std::to_string(nv + 1) + ": ";
            if (!std::isfinite(ci)) fail(path, ln, vertex + "non-finite coordinate '" + tok + "' (NaN or inf)");
            if (std::abs(ci) > kMaxCoordinate)
              fail(path, ln, vertex + "coordinate '" + tok + "' is beyond +-1e6, ccfr's bound on coordinates");
          }
          // After x y z, OBJ allows a weight w or a colour r g b (with or without w): numbers only.
          int extra = 0;
          while (ls >> tok) {
            char* end = nullptr;
            std::strtod(tok.c_str(), &end);
            if (*end != '\0' || tok.empty() || ++extra > 4)
              fail(path, ln, "unexpected '" + tok + "' after the vertex's coordinates");
          }
          fr.v.emplace_back(c[0], c[1], c[2]);
          current().vertex_end = static_cast<Index>(fr.v.size());
        } else if (tag == "f") {
          std::vector<Index> poly;
          while (ls >> tok) poly.push_back(parse_index(tok, nv, path, ln));
          if (poly.size() < 3) fail(path, ln, "face needs at least 3 vertices");
          if (poly.size() > 3) {
            // The fan from the first corner is the polygon only when every corner turns one way
            // about its normal (Newell's); a reflex corner would make a folded triangle.
            Vec3 n = Vec3::Zero();
            for (size_t k = 0; k < poly.size(); ++k) n += fr.v[poly[k]].cross(fr.v[poly[(k + 1) % poly.size()]]);
            for (size_t k = 0; k < poly.size(); ++k) {
              const Vec3& a = fr.v[poly[k]];
              const Vec3& b = fr.v[poly[(k + 1) % poly.size()]];
              const Vec3& c = fr.v[poly[(k + 2) % poly.size()]];
              if ((b - a).cross(c - b).dot(n) < 0.0)
                fail(path, ln,
                     "non-convex polygon (corner at vertex " + std::to_string(poly[(k + 1) % poly.size()] + 1) +
                         "): its fan triangulation would fold; triangulate it in the modelling tool");
            }
          }
          for (size_t k = 1; k + 1 < poly.size(); ++k) {
            fr.faces.emplace_back(poly[0], poly[k], poly[k + 1]);
            fr.face_lines.push_back(ln);
          }
          FrameObject& o = current();
          o.face_end = static_cast<Index>(fr.faces.size());
          if (o.first_face_line == 0) o.first_face_line = ln;
        } else if (tag == "l") {
          std::vector<Index> pl;
          while (ls >> tok) pl.push_back(parse_index(tok, nv, path, ln));
          if (pl.size() < 2) fail(path, ln, "line needs at least 2 vertices");
          // A strand visits each vertex once (a closed loop ends where it starts): `l 1 2 1 2`
          // would fold a strand onto itself.
          std::vector<Index> seen(pl.begin(), pl.end() - (pl.size() > 3 && pl.front() == pl.back() ? 1 : 0));
          std::sort(seen.begin(), seen.end());
          if (const auto twice = std::adjacent_find(seen.begin(), seen.end()); twice != seen.end())
            fail(path, ln,
                 "line visits vertex " + std::to_string(*twice + 1) +
                     " twice (only a closed loop may end where it starts)");
          fr.lines.push_back(std::move(pl));
          FrameObject& o = current();
          o.line_end = static_cast<Index>(fr.lines.size());
          if (o.first_line_line == 0) o.first_line_line = ln;
        } else if (tag == "p") {
          const size_t before = fr.points.size();
          while (ls >> tok) fr.points.push_back(parse_index(tok, nv, path, ln));
          if (fr.points.size() == before) fail(path, ln, "point statement needs at least 1 vertex");
          FrameObject& o = current();
          o.point_end = static_cast<Index>(fr.points.size());
          if (o.first_point_line == 0) o.first_point_line = ln;
        } else if (!ignored_statement(tag)) {
          // Free-form geometry (curv, surf, ...), `call` of another file or anything unknown would
          // carry elements that no reader downstream sees: refuse rather than drop them.
          fail(path, ln, "unsupported OBJ statement '" + tag + "' (only v, f, l, p, o and g carry geometry here)");
        }
      },
      &first_line);
  if (const std::string head = std::string("# ccfr frame ") + kFingerprintTag; first_line.rfind(head, 0) == 0) {
    const std::string hex = first_line.substr(head.size());
    char* end = nullptr;
    fr.scene_fingerprint = std::strtoull(hex.c_str(), &end, 16);
    if (hex.size() != 16 || *end != '\0') fail(path, 1, "bad scene fingerprint '" + hex + "'");
  }
  return fr;
}

ObjMesh read_obj_mesh(const fs::path& path) {
  check_user_file(path, "mesh file", kMaxMeshFileBytes);
  Frame fr = read_frame_obj(path);
  if (fr.v.empty()) throw Error("mesh file '" + path.string() + "' has no vertices");
  ObjMesh m{std::move(fr.v), std::move(fr.faces), std::move(fr.lines), std::move(fr.face_lines)};
  auto first = [](int& at, int line) {
    if (line > 0 && (at == 0 || line < at)) at = line;
  };
  for (const FrameObject& o : fr.objects) {
    first(m.first_line_line, o.first_line_line);
    first(m.first_point_line, o.first_point_line);
  }
  return m;
}

}  // namespace ccfr::io
