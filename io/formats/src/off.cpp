#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/user_file.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail(const fs::path& p, int line, const std::string& msg) {
  throw Error(printable(p.string()) + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " + printable(msg));
}

/// Tokens of a Geomview OFF file, line by line: `#` starts a comment anywhere on a line, blank
/// lines are skipped. Remembers the line of the token last read, for messages.
class Tokens {
 public:
  explicit Tokens(const fs::path& p) : path_(p), in_(p) {
    if (!in_) throw Error("cannot open '" + p.string() + "'");
  }
  /// Next non-empty line split into tokens; false at the end of the file.
  bool next_line(std::vector<std::string>& out) {
    out.clear();
    std::string s;
    while (std::getline(in_, s)) {
      ++line_;
      if (const auto hash = s.find('#'); hash != std::string::npos) s.resize(hash);
      std::istringstream ls(s);
      std::string tok;
      while (ls >> tok) out.push_back(tok);
      if (!out.empty()) return true;
    }
    return false;
  }
  int line() const { return line_; }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
  std::ifstream in_;
  int line_ = 0;
};

long parse_count(const std::string& tok, const Tokens& t, const char* what) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(tok.c_str(), &end, 10);
  if (tok.empty() || *end != '\0' || errno == ERANGE || v < 0)
    fail(t.path(), t.line(), std::string("bad ") + what + " count '" + tok + "'");
  return v;
}

double parse_coordinate(const std::string& tok, const Tokens& t) {
  char* end = nullptr;
  const double v = std::strtod(tok.c_str(), &end);
  if (tok.empty() || *end != '\0') fail(t.path(), t.line(), "bad coordinate '" + tok + "'");
  if (!std::isfinite(v)) fail(t.path(), t.line(), "non-finite coordinate '" + tok + "' (NaN or inf)");
  if (std::abs(v) > kMaxCoordinate)
    fail(t.path(), t.line(), "coordinate '" + tok + "' is beyond +-1e6, ccfr's bound on coordinates");
  return v;
}

}  // namespace

ObjMesh read_off_mesh(const fs::path& path) {
  const auto bytes = check_user_file(path, "mesh file", kMaxMeshFileBytes);
  Tokens t(path);
  std::vector<std::string> tok;
  if (!t.next_line(tok)) fail(path, 0, "empty OFF file");

  // Header keyword: [ST][C][N][4][n]OFF. Per-vertex normals, colours and texture coordinates follow
  // the three coordinates and are ignored; 4-D and n-D vertices, and the binary form, are refused.
  size_t at = 0;  // where the counts start on the current line
  const std::string head = tok[0];
  if (head.size() >= 3 && head.compare(head.size() - 3, 3, "OFF") == 0) {
    const std::string prefix = head.substr(0, head.size() - 3);
    if (prefix.find('4') != std::string::npos || prefix.find('n') != std::string::npos)
      fail(path, t.line(), "'" + head + "': only 3-D vertices are supported (no 4OFF or nOFF)");
    for (char c : prefix)
      if (c != 'S' && c != 'T' && c != 'C' && c != 'N') fail(path, t.line(), "unknown OFF header '" + head + "'");
    if (tok.size() > 1 && tok[1] == "BINARY") fail(path, t.line(), "binary OFF is not supported (write it as text)");
    at = 1;
  }
  // The counts line "#V #F #E" may share the header's line.
  if (tok.size() <= at) {
    if (!t.next_line(tok)) fail(path, t.line(), "missing the vertex and face counts");
    at = 0;
  }
  if (tok.size() < at + 2) fail(path, t.line(), "the counts line needs the vertex and face counts");
  const long nv = parse_count(tok[at], t, "vertex");
  const long nf = parse_count(tok[at + 1], t, "face");
  // Each vertex and face takes at least two bytes of text: larger counts cannot be in the file,
  // and reserving them would only exhaust memory.
  if (static_cast<unsigned long>(nv) > bytes / 2 || static_cast<unsigned long>(nf) > bytes / 2)
    fail(path, t.line(),
         "counts " + std::to_string(nv) + " vertices, " + std::to_string(nf) + " faces exceed what a " +
             std::to_string(bytes) + "-byte file can hold");
  if (nv == 0) fail(path, t.line(), "no vertices");

  ObjMesh m;
  m.v.reserve(static_cast<size_t>(nv));
  for (long i = 0; i < nv; ++i) {
    if (!t.next_line(tok))
      fail(path, t.line(), "ends after " + std::to_string(i) + " of " + std::to_string(nv) + " vertices");
    if (tok.size() < 3) fail(path, t.line(), "vertex needs 3 coordinates");
    m.v.emplace_back(parse_coordinate(tok[0], t), parse_coordinate(tok[1], t), parse_coordinate(tok[2], t));
  }
  m.f.reserve(static_cast<size_t>(nf));
  for (long i = 0; i < nf; ++i) {
    if (!t.next_line(tok))
      fail(path, t.line(), "ends after " + std::to_string(i) + " of " + std::to_string(nf) + " faces");
    const long n = parse_count(tok[0], t, "face vertex");
    if (n < 3) fail(path, t.line(), "face needs at least 3 vertices");
    if (tok.size() < static_cast<size_t>(n) + 1)
      fail(path, t.line(),
           "face declares " + std::to_string(n) + " vertices but lists " + std::to_string(tok.size() - 1));
    std::vector<Index> poly(static_cast<size_t>(n));
    for (long k = 0; k < n; ++k) {
      const std::string& s = tok[static_cast<size_t>(k) + 1];
      char* end = nullptr;
      errno = 0;
      const long idx = std::strtol(s.c_str(), &end, 10);
      if (s.empty() || *end != '\0' || errno == ERANGE) fail(path, t.line(), "bad vertex index '" + s + "'");
      if (idx < 0 || idx >= nv)
        fail(path, t.line(), "vertex index " + s + " out of range (0-based, " + std::to_string(nv) + " vertices)");
      poly[static_cast<size_t>(k)] = static_cast<Index>(idx);
    }
    // Anything after the indices is the face's colour.
    for (size_t k = 1; k + 1 < poly.size(); ++k) {
      m.f.emplace_back(poly[0], poly[k], poly[k + 1]);
      m.face_lines.push_back(t.line());
    }
  }
  // Geomview lists no edges even where #E > 0; anything left is data this reader would drop.
  if (t.next_line(tok))
    fail(path, t.line(), "unexpected data after the " + std::to_string(nf) + " faces declared in the counts line");
  return m;
}

}  // namespace ccfr::io
