// objects[i].shape of type mesh: a file (Wavefront .obj, .off, TetGen .node/.ele, Gmsh .msh; a
// closed surface filled with tets for a tet_solid), or in-memory arrays (load_scene_arrays).
#include <algorithm>
#include <cctype>

#include "../scene_schema.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/tet_mesh.hpp"
#include "ccfr/io/user_file.hpp"
#include "input.hpp"
#include "shapes.hpp"

namespace ccfr::io::scene {

schema::NodePtr mesh_schema() {
  using namespace schema;
  return map(
      "a mesh file: Wavefront .obj (triangles; `l` lines for strands; a closed surface makes a "
      "tet_solid through the tetgen program), TetGen .node/.ele or Gmsh .msh (v2, v4 ASCII) tet "
      "meshes for tet_solid",
      {{"path", string(std::nullopt, "path, relative to the scene file")},
       {"quality", number(2.0,
                          "tet_solid from a surface .obj or .off: tetgen's radius-edge ratio bound (-q) on the "
                          "inside; the surface itself is kept as given (-Y) unless max_volume is set; 0 "
                          "turns quality refinement off",
                          Range::up_to(100))},
       {"max_volume", number(0.0,
                             "tet_solid from a surface .obj or .off: largest tet volume (m³ of "
                             "the placed object, after transform.scale; tetgen -a; it lets tetgen split the "
                             "surface's triangles); 0 means no bound",
                             Range::up_to(kMaxLength))}});
}

RawGeometry read_mesh_file(const Input& in, const YAML::Node& s, ObjectKind kind, const std::string& path, double scale,
                           const std::function<void(bool, const std::string&)>& require) {
  RawGeometry g;
  const std::string ppath = path + ".shape.path";
  fs::path file = s["path"].as<std::string>();
  std::string ext = file.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const auto& exts = mesh_extensions();
  if (std::find(exts.begin(), exts.end(), ext) == exts.end()) {
    std::string list;
    for (const auto& e : exts) list += (list.empty() ? "" : ", ") + e;
    in.ctx.fail(ppath, in.in_node(ppath),
                ext.empty() ? "mesh file '" + file.string() + "' has no extension (supported: " + list + ")"
                            : "unsupported mesh format '" + file.extension().string() + "' (supported: " + list + ")");
  }
  if (file.is_relative()) file = in.base / file;
  fs::file_status st;
  try {
    st = user_path_status(file, "mesh file");
  } catch (const Error& e) {
    in.ctx.fail(ppath, in.in_node(ppath), e.what());
  }
  if (st.type() == fs::file_type::not_found && ext != ".node" && ext != ".ele")
    in.ctx.fail(ppath, in.in_node(ppath), "mesh file '" + file.string() + "' does not exist");
  const bool surface_file = ext == ".obj" || ext == ".off";
  // tetgen's settings do nothing unless tetgen fills a surface: a key given there is a mistake.
  if (!(surface_file && kind == ObjectKind::tet_solid))
    for (const char* key : {"quality", "max_volume"})
      if (const YAML::Node given = in.in_node(path + ".shape"); given.IsMap() && given[key])
        in.ctx.fail(path + ".shape." + key, given[key],
                    std::string("`") + key + "` applies only to a tet_solid filled from a surface .obj or .off (here " +
                        std::string(to_string(kind)) + " from " + ext + "): it would do nothing; remove it",
                    {path + ".kind"});
  if (!surface_file) {
    require(kind == ObjectKind::tet_solid, "a tet mesh (" + ext + ") makes a tet_solid object");
    TetMesh m;
    try {
      m = ext == ".msh" ? read_gmsh(file) : read_tetgen(file);
    } catch (const Error& e) {
      in.ctx.fail(ppath, in.in_node(ppath), std::string("cannot read mesh: ") + e.what());
    }
    g.v = std::move(m.v);
    g.tets = std::move(m.t);
    return g;
  }
  ObjMesh m;
  try {
    m = ext == ".off" ? read_off_mesh(file) : read_obj_mesh(file);
  } catch (const Error& e) {
    in.ctx.fail(ppath, in.in_node(ppath), std::string("cannot read mesh: ") + e.what());
  }
  if (kind == ObjectKind::tet_solid) {
    // A closed surface filled with tets by the tetgen program.
    if (m.f.empty()) in.ctx.fail(ppath, in.in_node(ppath), "mesh '" + file.string() + "' has no faces");
    check_faces(in, m.v, m.f, ObjectKind::tet_solid, "mesh '" + file.string() + "'", &m.face_lines, ppath,
                {path + ".kind"});
    TetMesh t;
    try {
      t = tetrahedralize(m.v, m.f, s["quality"].as<double>(), s["max_volume"].as<double>() / (scale * scale * scale),
                         "mesh '" + file.string() + "'", &m.face_lines);
    } catch (const Error& e) {
      in.ctx.fail(ppath, in.in_node(ppath), e.what());
    }
    g.v = std::move(t.v);
    g.tets = std::move(t.t);
    return g;
  }
  g.v = std::move(m.v);
  // Elements the object would not use are refused, naming their line, rather than dropped.
  const auto unused = [&](int line, const std::string& what) {
    if (line > 0)
      in.ctx.fail(ppath, in.in_node(ppath),
                  "'" + printable(file.string()) + "' line " + std::to_string(line) + ": " + what + " (kind " +
                      std::string(to_string(kind)) + " would drop them); remove them from the mesh",
                  {path + ".kind"});
  };
  unused(m.first_point_line, "`p` points are not read from mesh files");
  if (kind == ObjectKind::strand) {
    if (m.lines.empty())
      in.ctx.fail(ppath, in.in_node(ppath), "a strand mesh needs `l` lines; '" + file.string() + "' has none");
    if (!m.face_lines.empty()) unused(m.face_lines.front(), "`f` faces make no strands");
    g.lines = std::move(m.lines);
  } else {
    unused(m.first_line_line, "`l` lines are strands, not part of a surface");
    require(surface_kind(kind), "meshes make cloth, shell, obstacle, rigid or strand objects");
    if (m.f.empty()) in.ctx.fail(ppath, in.in_node(ppath), "mesh '" + file.string() + "' has no faces");
    check_faces(in, g.v, m.f, kind, "mesh '" + file.string() + "'", &m.face_lines, ppath, {path + ".kind"});
    g.faces = std::move(m.f);
  }
  return g;
}

/// Geometry from in-memory arrays (load_scene_arrays): the checks of a mesh file, plus those of
/// edges and tets, which no file format of the loader carries.
RawGeometry read_mesh_arrays(const Input& in, const MeshArrays& a, ObjectKind kind, const std::string& path,
                             const std::function<void(bool, const std::string&)>& require) {
  RawGeometry g;
  const Index nv = static_cast<Index>(a.vertices.size());
  const std::string vpath = path + ".vertices";
  if (nv == 0) in.ctx.fail(vpath, in.in_node(path), "no vertices");
  for (Index i = 0; i < nv; ++i)
    if (!a.vertices[i].allFinite())
      in.ctx.fail(vpath, in.in_node(path), "vertex " + std::to_string(i) + " is not finite");
  auto check_range = [&](const std::string& what, const auto& rows) {
    for (size_t r = 0; r < rows.size(); ++r)
      for (int k = 0; k < rows[r].size(); ++k)
        if (rows[r][k] < 0 || rows[r][k] >= nv)
          in.ctx.fail(path + "." + what, in.in_node(path),
                      what + " row " + std::to_string(r) + ": vertex index " + std::to_string(rows[r][k]) +
                          " out of range (the object has " + std::to_string(nv) + " vertices)");
  };
  check_range("faces", a.faces);
  check_range("edges", a.edges);
  check_range("tets", a.tets);
  auto only = [&](bool ok, const std::string& what) {
    if (!ok) require(false, what);
  };
  g.v = a.vertices;
  if (kind == ObjectKind::strand) {
    only(a.faces.empty() && a.tets.empty(), "a strand takes edges, not faces or tets");
    if (a.edges.empty()) in.ctx.fail(path + ".edges", in.in_node(path), "a strand needs edges");
    for (size_t r = 0; r < a.edges.size(); ++r) {
      const Vec2i& e = a.edges[r];
      if (e[0] == e[1])
        in.ctx.fail(path + ".edges", in.in_node(path),
                    "edges row " + std::to_string(r) + " repeats vertex " + std::to_string(e[0]));
      if (g.lines.empty() || g.lines.back().back() != e[0]) g.lines.push_back({e[0]});
      g.lines.back().push_back(e[1]);
    }
  } else if (kind == ObjectKind::tet_solid) {
    only(a.faces.empty() && a.edges.empty(), "a tet_solid takes tets (its surface is derived), not faces or edges");
    if (a.tets.empty()) in.ctx.fail(path + ".tets", in.in_node(path), "a tet_solid needs tets");
    for (size_t r = 0; r < a.tets.size(); ++r) {
      const Vec4i& t = a.tets[r];
      const Vec3 e1 = g.v[t[1]] - g.v[t[0]], e2 = g.v[t[2]] - g.v[t[0]], e3 = g.v[t[3]] - g.v[t[0]];
      const double scale = std::max({e1.norm(), e2.norm(), e3.norm()});
      const double vol6 = e1.cross(e2).dot(e3);
      if (!(vol6 > 1e-12 * scale * scale * scale))
        in.ctx.fail(path + ".tets", in.in_node(path),
                    "tets row " + std::to_string(r) + " has " + (vol6 < 0 ? "negative" : "zero") +
                        " volume; order each tet (a, b, c, d) so that (b-a)x(c-a).(d-a) > 0");
    }
    g.tets = a.tets;
  } else if (kind == ObjectKind::particles) {
    only(a.faces.empty() && a.edges.empty() && a.tets.empty(), "particles take vertices only");
  } else {
    only(surface_kind(kind) && a.edges.empty() && a.tets.empty(),
         "a " + std::string(to_string(kind)) + " takes faces, not edges or tets");
    if (a.faces.empty())
      in.ctx.fail(path + ".faces", in.in_node(path), "a " + std::string(to_string(kind)) + " needs faces");
    check_faces(in, g.v, a.faces, kind, "faces", nullptr, path + ".faces", {path + ".kind"});
    g.faces = a.faces;
  }
  return g;
}

}  // namespace ccfr::io::scene
