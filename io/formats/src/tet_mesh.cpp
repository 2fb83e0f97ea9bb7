#include "ccfr/io/tet_mesh.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <unordered_map>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/process.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/user_file.hpp"

namespace ccfr::io {

namespace fs = std::filesystem;

const std::vector<std::string>& mesh_extensions() {
  static const std::vector<std::string> e{".obj", ".off", ".node", ".ele", ".msh"};
  return e;
}

namespace {

/// The shortest edge (same units as `v`) among the elements' vertex pairs: triangles or tets.
template <class Element>
double shortest_edge(const Positions& v, const std::vector<Element>& elements) {
  double best = std::numeric_limits<double>::infinity();
  for (const Element& e : elements)
    for (int a = 0; a < e.size(); ++a)
      for (int b = a + 1; b < e.size(); ++b) best = std::min(best, (v[e[a]] - v[e[b]]).norm());
  return best;
}

[[noreturn]] void fail(const fs::path& p, int line, const std::string& msg) {
  throw Error(printable(p.string()) + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " + printable(msg));
}

/// Reads a whitespace-separated file line by line, skipping blank lines and `#` comments
/// (TetGen's convention; Gmsh has none inside sections).
class Lines {
 public:
  // The stat check runs before the stream opens the file: a FIFO would block in the open.
  explicit Lines(const fs::path& p) : path_(p), bytes_(check_user_file(p, "mesh file", kMaxMeshFileBytes)), in_(p) {
    if (!in_) throw Error("cannot open '" + printable(p.string()) + "'");
  }
  /// The file's size: a count in a header larger than the file can hold is refused before allocating.
  std::uintmax_t bytes() const { return bytes_; }
  /// The next non-empty line's tokens; false at the end of the file.
  bool next(std::istringstream& ls) {
    std::string s;
    while (std::getline(in_, s)) {
      ++line_;
      const auto hash = s.find('#');
      if (hash != std::string::npos) s.erase(hash);
      if (s.find_first_not_of(" \t\r") == std::string::npos) continue;
      ls.clear();
      ls.str(s);
      return true;
    }
    return false;
  }
  /// The next line, which must exist (`what` names what was expected).
  std::istringstream& need(const std::string& what) {
    if (!next(ls_)) fail(path_, line_, "unexpected end of file, expected " + what);
    return ls_;
  }
  int line() const { return line_; }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
  std::uintmax_t bytes_ = 0;
  std::ifstream in_;
  std::istringstream ls_;
  int line_ = 0;
};

template <class T>
T get(std::istringstream& ls, Lines& f, const char* what) {
  T v{};
  if (!(ls >> v)) fail(f.path(), f.line(), std::string("expected ") + what);
  return v;
}

double coord(std::istringstream& ls, Lines& f) {
  const double c = get<double>(ls, f, "a coordinate");
  if (!std::isfinite(c)) fail(f.path(), f.line(), "non-finite coordinate");
  if (std::abs(c) > kMaxCoordinate)
    fail(f.path(), f.line(), "coordinate " + std::to_string(c) + " is beyond +-1e6, ccfr's bound on coordinates");
  return c;
}

/// Keeps the nodes used by tets (in their order of first use), orients every tet positively and
/// refuses degenerate ones. `lines` gives each tet's source line for messages.
TetMesh finish(const Positions& nodes, std::vector<Vec4i> tets, const std::vector<int>& lines, const fs::path& p) {
  if (tets.empty()) fail(p, 0, "no tetrahedra in the file");
  TetMesh m;
  std::vector<Index> remap(nodes.size(), -1);
  for (size_t k = 0; k < tets.size(); ++k) {
    Vec4i& t = tets[k];
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < i; ++j)
        if (t[i] == t[j]) fail(p, lines[k], "tetrahedron " + std::to_string(k + 1) + " repeats a node");
    for (int i = 0; i < 4; ++i) {
      Index& r = remap[t[i]];
      if (r < 0) {
        r = static_cast<Index>(m.v.size());
        m.v.push_back(nodes[t[i]]);
      }
      t[i] = r;
    }
    const Vec3 a = m.v[t[1]] - m.v[t[0]], b = m.v[t[2]] - m.v[t[0]], c = m.v[t[3]] - m.v[t[0]];
    const double vol = a.cross(b).dot(c) / 6.0;
    const double scale = std::max({a.norm(), b.norm(), c.norm()});
    if (!(std::abs(vol) > 1e-12 * scale * scale * scale))
      fail(p, lines[k], "tetrahedron " + std::to_string(k + 1) + " has zero volume (its nodes are coplanar)");
    if (vol < 0) std::swap(t[2], t[3]);
  }
  m.t = std::move(tets);
  return m;
}

}  // namespace

TetMesh read_tetgen(const fs::path& path) {
  const fs::path node = fs::path(path).replace_extension(".node"), ele = fs::path(path).replace_extension(".ele");
  Lines nf(node);
  auto& h = nf.need("the header '<#nodes> 3 <#attributes> <#markers>'");
  const long n = get<long>(h, nf, "the number of nodes");
  const int dim = get<int>(h, nf, "the dimension");
  int attrs = 0, markers = 0;
  h >> attrs >> markers;
  if (dim != 3) fail(node, nf.line(), "dimension " + std::to_string(dim) + ", expected 3");
  if (n <= 0) fail(node, nf.line(), "no nodes");
  // A node line "<id> <x> <y> <z>" takes at least 8 bytes.
  if (static_cast<std::uintmax_t>(n) > nf.bytes() / 8)
    fail(node, nf.line(),
         std::to_string(n) + " nodes exceed what a " + std::to_string(nf.bytes()) + "-byte file can hold");
  Positions nodes(static_cast<size_t>(n));
  long first = 0;
  for (long k = 0; k < n; ++k) {
    auto& ls = nf.need("node " + std::to_string(k + 1) + " of " + std::to_string(n));
    const long id = get<long>(ls, nf, "a node number");
    if (k == 0) first = id;
    if (first != 0 && first != 1) fail(node, nf.line(), "node numbers start at 0 or 1, not " + std::to_string(first));
    if (id != first + k)
      fail(node, nf.line(), "node number " + std::to_string(id) + ", expected " + std::to_string(first + k));
    const double x = coord(ls, nf), y = coord(ls, nf), z = coord(ls, nf);
    nodes[k] = Vec3(x, y, z);
  }
  Lines ef(ele);
  auto& eh = ef.need("the header '<#tets> <4 or 10> <#attributes>'");
  const long nt = get<long>(eh, ef, "the number of tetrahedra");
  const int per = get<int>(eh, ef, "nodes per tetrahedron");
  if (per != 4 && per != 10) fail(ele, ef.line(), std::to_string(per) + " nodes per tetrahedron, expected 4 or 10");
  std::vector<Vec4i> tets;
  std::vector<int> lines;
  for (long k = 0; k < nt; ++k) {
    auto& ls = ef.need("tetrahedron " + std::to_string(k + 1) + " of " + std::to_string(nt));
    get<long>(ls, ef, "a tetrahedron number");
    Vec4i t;
    for (int i = 0; i < 4; ++i) {
      const long id = get<long>(ls, ef, "4 node numbers");
      if (id < first || id >= first + n)
        fail(ele, ef.line(),
             "node " + std::to_string(id) + " out of range (" + node.filename().string() + " has " +
                 std::to_string(first) + ".." + std::to_string(first + n - 1) + ")");
      t[i] = static_cast<Index>(id - first);
    }
    tets.push_back(t);
    lines.push_back(ef.line());
  }
  return finish(nodes, std::move(tets), lines, ele);
}

TetMesh read_gmsh(const fs::path& path) {
  Lines f(path);
  std::istringstream* ls = &f.need("$MeshFormat");
  std::string tok;
  *ls >> tok;
  if (tok != "$MeshFormat") fail(path, f.line(), "not a Gmsh mesh: the file does not start with $MeshFormat");
  ls = &f.need("the format line '<version> <file-type> <data-size>'");
  const double version = get<double>(*ls, f, "the format version");
  const int binary = get<int>(*ls, f, "the file type");
  if (binary != 0)
    fail(path, f.line(),
         "binary .msh is not supported; save the mesh as ASCII (Gmsh: -format msh2 or msh4 with Binary=0)");
  if (!(version >= 2.0 && version < 3.0) && !(version >= 4.0 && version < 5.0))
    fail(path, f.line(), "Gmsh format " + std::to_string(version).substr(0, 3) + " is not supported (2.x or 4.x)");
  const bool v4 = version >= 4.0;
  std::unordered_map<long, Index> node_of;  // Gmsh node tag -> index in `nodes`
  Positions nodes;
  std::vector<Vec4i> tets;
  std::vector<int> lines;
  auto node_index = [&](long tag) {
    const auto it = node_of.find(tag);
    if (it == node_of.end())
      fail(path, f.line(), "element uses node " + std::to_string(tag) + ", which $Nodes does not define");
    return it->second;
  };
  auto add_node = [&](long tag, const Vec3& x) {
    if (!node_of.emplace(tag, static_cast<Index>(nodes.size())).second)
      fail(path, f.line(), "node " + std::to_string(tag) + " is defined twice");
    nodes.push_back(x);
  };
  auto element = [&](int type, std::istringstream& s) {
    if (type != 4 && type != 11) return;  // 4: 4-node tetrahedron, 11: 10-node (corners first)
    Vec4i t;
    for (int i = 0; i < 4; ++i) t[i] = node_index(get<long>(s, f, "the element's node tags"));
    tets.push_back(t);
    lines.push_back(f.line());
  };
  // A section's count covers its lines; a missing end marker means the counts and the file disagree.
  auto end_section = [&](const char* marker) {
    std::string end;
    f.need(marker) >> end;
    if (end != marker)
      fail(path, f.line(), std::string("expected ") + marker + " after the section's last entry, found '" + end + "'");
  };
  std::istringstream s;
  while (f.next(s)) {
    s >> tok;
    if (tok == "$Nodes") {
      auto& h = f.need("the $Nodes header");
      if (!v4) {
        const long n = get<long>(h, f, "the number of nodes");
        for (long k = 0; k < n; ++k) {
          auto& l = f.need("a node");
          const long tag = get<long>(l, f, "a node tag");
          const double x = coord(l, f), y = coord(l, f), z = coord(l, f);
          add_node(tag, Vec3(x, y, z));
        }
      } else {
        const long blocks = get<long>(h, f, "the number of entity blocks");
        for (long b = 0; b < blocks; ++b) {
          auto& bh = f.need("a node block header");
          get<int>(bh, f, "the entity dimension");
          get<int>(bh, f, "the entity tag");
          const int parametric = get<int>(bh, f, "the parametric flag");
          const long n = get<long>(bh, f, "the number of nodes in the block");
          if (parametric != 0) fail(path, f.line(), "parametric node coordinates are not supported");
          std::vector<long> tags;
          for (long k = 0; k < n; ++k) tags.push_back(get<long>(f.need("a node tag"), f, "a node tag"));
          for (long k = 0; k < n; ++k) {
            auto& l = f.need("node coordinates");
            const double x = coord(l, f), y = coord(l, f), z = coord(l, f);
            add_node(tags[k], Vec3(x, y, z));
          }
        }
      }
      end_section("$EndNodes");
    } else if (tok == "$Elements") {
      auto& h = f.need("the $Elements header");
      if (!v4) {
        const long n = get<long>(h, f, "the number of elements");
        for (long k = 0; k < n; ++k) {
          auto& l = f.need("an element");
          get<long>(l, f, "an element tag");
          const int type = get<int>(l, f, "an element type");
          const int ntags = get<int>(l, f, "the number of tags");
          for (int i = 0; i < ntags; ++i) get<long>(l, f, "a tag");
          element(type, l);
        }
      } else {
        const long blocks = get<long>(h, f, "the number of entity blocks");
        for (long b = 0; b < blocks; ++b) {
          auto& bh = f.need("an element block header");
          get<int>(bh, f, "the entity dimension");
          get<int>(bh, f, "the entity tag");
          const int type = get<int>(bh, f, "the element type");
          const long n = get<long>(bh, f, "the number of elements in the block");
          for (long k = 0; k < n; ++k) {
            auto& l = f.need("an element");
            get<long>(l, f, "an element tag");
            element(type, l);
          }
        }
      }
      end_section("$EndElements");
    }
    // Other sections ($Entities, $PhysicalNames, ...) carry no geometry ccfr uses: skipped line by line.
  }
  if (nodes.empty()) fail(path, 0, "no $Nodes section");
  return finish(nodes, std::move(tets), lines, path);
}

TetMesh tetrahedralize(const Positions& v, const std::vector<Vec3i>& f, double quality, double max_volume,
                       const std::string& what, const std::vector<int>* face_lines) {
  const auto tetgen = find_program("tetgen");
  if (!tetgen)
    throw Error(what +
                ": a tet_solid from a surface needs the `tetgen` program (Debian package tetgen; "
                "scripts/install-deps installs it)");
  char tmpl[] = "/tmp/ccfr-tetgen-XXXXXX";
  if (!::mkdtemp(tmpl)) throw Error(what + ": cannot create a temporary folder for tetgen");
  const fs::path dir = tmpl;
  struct Cleanup {
    fs::path d;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(d, ec);
    }
  } cleanup{dir};
  {
    std::ofstream off(dir / "surface.off");
    off.precision(17);
    off << "OFF\n" << v.size() << " " << f.size() << " 0\n";
    for (const Vec3& p : v) off << p.x() << " " << p.y() << " " << p.z() << "\n";
    for (const Vec3i& t : f) off << "3 " << t[0] << " " << t[1] << " " << t[2] << "\n";
    if (!off) throw Error(what + ": cannot write the surface for tetgen into " + dir.string());
  }
  // -Y keeps the surface as given (no Steiner point on it). Without it tetgen splits surface edges
  // and faces to recover them, and on scanned surfaces puts points nanometres from the input's
  // (CGAL's triceratops: a 7e-7 edge against its own shortest of 0.02; the contact terms of the
  // memory estimate and the offset advice then scale with that edge). Interior points obey -q.
  std::string options;
  char num[64];
  if (quality > 0) {
    std::snprintf(num, sizeof num, "q%.17g", quality);
    options += num;
  }
  if (max_volume > 0) {
    std::snprintf(num, sizeof num, "a%.17g", max_volume);
    options += num;
  }
  const fs::path log = dir / "tetgen.log";
  // A volume bound needs the surface split (a tet on three surface vertices cannot shrink otherwise).
  std::string flags = (max_volume > 0 ? "-pQ" : "-pYQ") + options;
  int rc = run_process({tetgen->string(), flags, (dir / "surface.off").string()}, log);
  if (max_volume <= 0 && (rc != 0 || !fs::exists(dir / "surface.1.ele"))) {
    // A surface tetgen cannot keep unsplit: let it split the surface (the fill then warns below).
    flags = "-pQ" + options;
    rc = run_process({tetgen->string(), flags, (dir / "surface.off").string()}, log);
  }
  if (rc != 0 || !fs::exists(dir / "surface.1.ele")) {
    // tetgen -p aborts on a self-intersecting surface without saying so (CGAL's cow, bull, elk,
    // camel: "terminate called after throwing an instance of 'int'"); -d names the faces.
    const fs::path check = dir / "intersections.log";
    run_process({tetgen->string(), "-dNEF", (dir / "surface.off").string()}, check);
    std::ifstream cin(check);
    long pairs = 0, a = 0, b = 0;
    for (std::string l; std::getline(cin, l);) {
      if (a == 0 && std::sscanf(l.c_str(), " Facet #%ld intersects facet #%ld", &a, &b) == 2) continue;
      if (std::sscanf(l.c_str(), "!! Found %ld pairs of faces are intersecting", &pairs) == 1) break;
    }
    const auto face = [&](long k) {  // tetgen's facets are 1-based, in the order written
      const size_t i = static_cast<size_t>(k - 1);
      return face_lines && i < face_lines->size() && (*face_lines)[i] > 0
                 ? "the face of line " + std::to_string((*face_lines)[i])
                 : "face " + std::to_string(k - 1);
    };
    if (pairs > 0 && a > 0 && b > 0)
      throw Error(what + ": the surface intersects itself (" + std::to_string(pairs) + " pair" +
                  (pairs == 1 ? "" : "s") + " of faces, e.g. " + face(a) + " and " + face(b) +
                  "): tetgen cannot fill it; repair the surface (remove the self-intersections) or make the object "
                  "a shell or a rigid body, which need no fill");
    std::ifstream in(log);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>()), last;
    std::istringstream ss(text);
    for (std::string l; std::getline(ss, l);)
      if (l.find_first_not_of(" \t") != std::string::npos) last = l;
    throw Error(what + ": tetgen " + flags + " failed (exit " + std::to_string(rc) + ")" +
                (last.empty() ? std::string() : ": " + last) +
                "; is the surface closed and free of self-intersections?");
  }
  TetMesh t = read_tetgen(dir / "surface.1.ele");
  // Expected: edges near the surface's shortest, or near a regular tet's of volume max_volume,
  // (6√2 V)^(1/3); a tenth of the smaller of the two is a fill split around slivers.
  const double surface_edge = shortest_edge(v, f), fill_edge = shortest_edge(t.v, t.t);
  const double expected =
      max_volume > 0 ? std::min(surface_edge, std::cbrt(6 * std::sqrt(2.0) * max_volume)) : surface_edge;
  if (fill_edge < 0.1 * expected)
    log::warn(
        "{}: tetgen {} made edges down to {:.3g} (the surface's shortest is {:.3g}); contact and memory "
        "scale with the shortest edge: remesh the surface (fewer, more even triangles) if the run is slow",
        what, flags, fill_edge, surface_edge);
  return t;
}

}  // namespace ccfr::io
