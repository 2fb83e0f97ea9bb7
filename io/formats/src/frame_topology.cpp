#include "ccfr/io/frame_topology.hpp"

#include <algorithm>
#include <string>
#include <utility>

#include "ccfr/core/error.hpp"

namespace ccfr::io {

namespace {

std::string where(const std::filesystem::path& source, int line) {
  std::string s = source.empty() ? std::string("frame") : source.string();
  if (line > 0) s += ":" + std::to_string(line);
  return s;
}

Index local(Index v, const FrameObject& o, const char* what, const std::filesystem::path& source, int line) {
  if (v < o.vertex_begin || v >= o.vertex_end)
    throw Error(where(source, line) + ": object '" + o.name + "': a " + what + " uses vertex " + std::to_string(v + 1) +
                ", outside the object's vertices " + std::to_string(o.vertex_begin + 1) + ".." +
                std::to_string(o.vertex_end));
  return v - o.vertex_begin;
}

}  // namespace

Topology topology_from_frame(const Frame& frame, const std::filesystem::path& source) {
  TopologyBuilder builder;
  Index covered = 0;
  for (const FrameObject& o : frame.objects) {
    if (o.vertex_begin != covered)
      throw Error(where(source, o.line) + ": object '" + o.name +
                  "': its vertices do not follow the previous object's");
    covered = o.vertex_end;
    const bool has_faces = o.face_end > o.face_begin, has_lines = o.line_end > o.line_begin,
               has_points = o.point_end > o.point_begin;
    if (has_faces + has_lines + has_points > 1) {
      // The audit decides by object what a primitive is: strand segments are tested against
      // triangles and particles as points only in their own objects. A mixed block would lose them.
      const int second = std::max(
          {has_faces ? o.first_face_line : 0, has_lines ? o.first_line_line : 0, has_points ? o.first_point_line : 0});
      std::string kinds;
      for (auto [has, name] : {std::pair{has_faces, "faces (f)"}, {has_lines, "lines (l)"}, {has_points, "points (p)"}})
        if (has) kinds += (kinds.empty() ? "" : " and ") + std::string(name);
      throw Error(where(source, second) + ": object '" + o.name + "' mixes " + kinds +
                  "; put each kind of element in its own `o` block");
    }
    if (!has_faces && !has_lines && !has_points && o.vertex_end > o.vertex_begin)
      throw Error(where(source, o.line) + ": object '" + o.name + "' has " +
                  std::to_string(o.vertex_end - o.vertex_begin) +
                  " vertices but no f, l or p element, so nothing of it could be audited (list free points with `p`)");
    std::vector<Vec3i> faces;
    for (Index f = o.face_begin; f < o.face_end; ++f) {
      const Vec3i& t = frame.faces[f];
      faces.emplace_back(local(t[0], o, "face", source, o.first_face_line),
                         local(t[1], o, "face", source, o.first_face_line),
                         local(t[2], o, "face", source, o.first_face_line));
    }
    std::vector<std::vector<Index>> lines;
    for (Index l = o.line_begin; l < o.line_end; ++l) {
      std::vector<Index> line;
      for (Index v : frame.lines[l]) line.push_back(local(v, o, "line", source, o.first_line_line));
      lines.push_back(std::move(line));
    }
    for (Index p = o.point_begin; p < o.point_end; ++p) local(frame.points[p], o, "point", source, o.first_point_line);
    const ObjectKind kind = has_lines ? ObjectKind::strand : has_points ? ObjectKind::particles : ObjectKind::shell;
    builder.add_object(o.name, kind, o.vertex_end - o.vertex_begin, faces, {}, lines);
  }
  if (covered != static_cast<Index>(frame.v.size()))
    throw Error(where(source, 0) + ": " + std::to_string(frame.v.size() - covered) + " vertices belong to no object");
  return builder.finish();
}

Index unreferenced_vertices(const Topology& t) {
  std::vector<char> used(static_cast<size_t>(t.num_vertices()), 0);
  for (const Vec3i& f : t.faces)
    for (int k = 0; k < 3; ++k) used[f[k]] = 1;
  for (const Vec2i& e : t.edges) used[e[0]] = used[e[1]] = 1;
  for (const ObjectInfo& o : t.objects)
    if (o.kind == ObjectKind::particles)
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v) used[v] = 1;
  return static_cast<Index>(std::count(used.begin(), used.end(), 0));
}

bool same_structure(const Frame& a, const Frame& b) {
  if (a.v.size() != b.v.size() || a.faces != b.faces || a.lines != b.lines || a.points != b.points ||
      a.objects.size() != b.objects.size())
    return false;
  for (size_t i = 0; i < a.objects.size(); ++i) {
    const FrameObject &x = a.objects[i], &y = b.objects[i];
    if (x.name != y.name || x.vertex_begin != y.vertex_begin || x.vertex_end != y.vertex_end ||
        x.face_begin != y.face_begin || x.face_end != y.face_end || x.line_begin != y.line_begin ||
        x.line_end != y.line_end || x.point_begin != y.point_begin || x.point_end != y.point_end)
      return false;
  }
  return true;
}

}  // namespace ccfr::io
