#include "ccfr/io/frame_topology.hpp"

#include <string>

#include "ccfr/core/error.hpp"

namespace ccfr::io {

namespace {

Index local(Index v, const FrameObject& o, const char* what) {
  if (v < o.vertex_begin || v >= o.vertex_end)
    throw Error("frame object '" + o.name + "': a " + what + " uses vertex " + std::to_string(v + 1) +
                ", outside the object's vertices " + std::to_string(o.vertex_begin + 1) + ".." +
                std::to_string(o.vertex_end));
  return v - o.vertex_begin;
}

}  // namespace

Topology topology_from_frame(const Frame& frame) {
  TopologyBuilder builder;
  Index covered = 0;
  for (const FrameObject& o : frame.objects) {
    if (o.vertex_begin != covered)
      throw Error("frame object '" + o.name + "': its vertices do not follow the previous object's");
    covered = o.vertex_end;
    std::vector<Vec3i> faces;
    for (Index f = o.face_begin; f < o.face_end; ++f) {
      const Vec3i& t = frame.faces[f];
      faces.emplace_back(local(t[0], o, "face"), local(t[1], o, "face"), local(t[2], o, "face"));
    }
    std::vector<std::vector<Index>> lines;
    for (Index l = o.line_begin; l < o.line_end; ++l) {
      std::vector<Index> line;
      for (Index v : frame.lines[l]) line.push_back(local(v, o, "line"));
      lines.push_back(std::move(line));
    }
    for (Index p = o.point_begin; p < o.point_end; ++p) local(frame.points[p], o, "point");
    ObjectKind kind = ObjectKind::shell;
    if (faces.empty() && !lines.empty())
      kind = ObjectKind::strand;
    else if (faces.empty() && o.point_end > o.point_begin)
      kind = ObjectKind::particles;
    builder.add_object(o.name, kind, o.vertex_end - o.vertex_begin, faces, {}, lines);
  }
  if (covered != static_cast<Index>(frame.v.size()))
    throw Error("frame: " + std::to_string(frame.v.size() - covered) + " vertices belong to no object");
  return builder.finish();
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
