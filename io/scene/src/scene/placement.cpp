// The checks of an object's surface and placement: degenerate faces, objects[i].transform.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <numbers>

#include "ccfr/core/bounds.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/geometry/mass_properties.hpp"
#include "input.hpp"

namespace ccfr::io::scene {

/// Degenerate surfaces: faces that repeat a vertex, have no area or repeat another face, edges
/// shared by more than two faces, and open surfaces used as rigid bodies (whose mass comes from
/// the enclosed volume). Errors name the face (1-based, after triangulation) and its OBJ line;
/// what a user may reasonably want (zero-area obstacle faces, non-manifold cloth) is a warning.
void check_faces(const Input& in, const Positions& v, const std::vector<Vec3i>& faces, ObjectKind kind,
                 const std::string& what, const std::vector<int>* lines, const std::string& path,
                 const std::vector<std::string>& related) {
  auto face = [&](size_t i) {
    std::string w = "face " + std::to_string(i + 1);
    if (lines && i < lines->size()) w += " (line " + std::to_string((*lines)[i]) + ")";
    return w;
  };
  auto fail = [&](const std::string& msg) { in.ctx.fail(path, in.in_node(path), what + ": " + msg, related); };
  const bool rigid = kind == ObjectKind::rigid;
  // A rigid body's mass and a tet_solid's tets both come from the enclosed volume.
  const bool solid = rigid || kind == ObjectKind::tet_solid;
  size_t zero_area = 0, first_zero = 0;
  for (size_t i = 0; i < faces.size(); ++i) {
    const Vec3i& f = faces[i];
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2])
      fail(face(i) + " repeats vertex " + std::to_string((f[0] == f[1] || f[0] == f[2] ? f[0] : f[1]) + 1));
    const Vec3 e1 = v[f[1]] - v[f[0]], e2 = v[f[2]] - v[f[0]], e3 = v[f[2]] - v[f[1]];
    const double l2 = std::max({e1.squaredNorm(), e2.squaredNorm(), e3.squaredNorm()});
    if (!(e1.cross(e2).norm() > 1e-12 * l2) || l2 == 0.0) {
      if (zero_area++ == 0) first_zero = i;
    }
  }
  if (zero_area > 0) {
    const std::string msg = face(first_zero) + " has zero area (its vertices coincide or are collinear)" +
                            (zero_area > 1 ? "; " + std::to_string(zero_area) + " such faces in all" : std::string());
    if (kind != ObjectKind::obstacle) fail(msg);
    log::warn("{}: {}: {}: {}", in.ctx.file, path, what, msg);
  }
  // Duplicate faces (the same three vertices in any order).
  std::vector<std::pair<std::array<Index, 3>, size_t>> sorted(faces.size());
  for (size_t i = 0; i < faces.size(); ++i) {
    std::array<Index, 3> k{faces[i][0], faces[i][1], faces[i][2]};
    std::sort(k.begin(), k.end());
    sorted[i] = {k, i};
  }
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 1; i < sorted.size(); ++i)
    if (sorted[i].first == sorted[i - 1].first) fail(face(sorted[i].second) + " repeats " + face(sorted[i - 1].second));
  // Edge valence: 2 everywhere on a closed manifold surface.
  std::vector<std::pair<std::pair<Index, Index>, size_t>> edges;
  edges.reserve(3 * faces.size());
  for (size_t i = 0; i < faces.size(); ++i)
    for (int k = 0; k < 3; ++k) edges.push_back({std::minmax(faces[i][k], faces[i][(k + 1) % 3]), i});
  std::sort(edges.begin(), edges.end());
  size_t non_manifold = 0, open = 0, first_nm = 0, first_open = 0;
  std::pair<Index, Index> nm_edge, open_edge;
  for (size_t b = 0; b < edges.size();) {
    size_t e = b;
    while (e < edges.size() && edges[e].first == edges[b].first) ++e;
    if (e - b > 2 && non_manifold++ == 0) first_nm = edges[b + 2].second, nm_edge = edges[b].first;
    if (e - b == 1 && open++ == 0) first_open = edges[b].second, open_edge = edges[b].first;
    b = e;
  }
  auto edge_str = [](std::pair<Index, Index> e) {
    return "(" + std::to_string(e.first + 1) + ", " + std::to_string(e.second + 1) + ")";
  };
  if (non_manifold > 0) {
    const std::string msg =
        "edge " + edge_str(nm_edge) + " of " + face(first_nm) + " is shared by more than two faces (non-manifold)" +
        (non_manifold > 1 ? "; " + std::to_string(non_manifold) + " such edges in all" : std::string());
    if (solid) fail(msg);
    log::warn("{}: {}: {}: {}", in.ctx.file, path, what, msg);
  }
  const std::string needs = rigid ? "a rigid body needs a closed surface (its mass comes from the enclosed volume)"
                                  : "a tet_solid from a surface needs a closed surface (tetgen fills the inside)";
  if (solid && open > 0)
    fail(needs + ", but edge " + edge_str(open_edge) + " of " + face(first_open) + " borders only one face (" +
         std::to_string(open) + " open edges in all)");
  if (!solid) return;
  // Consistent winding: on a closed oriented surface every edge runs once each way.
  for (size_t b = 0; b + 1 < edges.size(); b += 2) {
    const Vec3i& f = faces[edges[b].second];
    const Vec3i& g = faces[edges[b + 1].second];
    auto runs_forward = [&](const Vec3i& t) {
      for (int k = 0; k < 3; ++k)
        if (t[k] == edges[b].first.first && t[(k + 1) % 3] == edges[b].first.second) return true;
      return false;
    };
    if (runs_forward(f) == runs_forward(g))
      fail(face(edges[b + 1].second) + " is wound against " + face(edges[b].second) + " (their common edge " +
           edge_str(edges[b].first) + " runs the same way in both); orient all faces outward");
  }
  const SolidMassProperties props = solid_mass_properties(v, faces);
  Vec3 lo = v[faces[0][0]], hi = lo;
  for (const Vec3i& f : faces)
    for (int k = 0; k < 3; ++k) lo = lo.cwiseMin(v[f[k]]), hi = hi.cwiseMax(v[f[k]]);
  const double diagonal = (hi - lo).norm();
  if (!(props.volume > 1e-9 * diagonal * diagonal * diagonal))
    fail(
        ccfr::format("the closed surface encloses no volume ({:.3g} m³ inside a bounding box of diagonal {:.3g} m): "
                     "a flat surface cannot be a solid",
                     props.volume, diagonal));
  if (props.inverted)
    log::info("{}: {}: {}: faces wound inward; taken as the solid they enclose", in.ctx.file, path, what);
}

/// A rotation by a non-zero angle about the zero vector has no axis: an error at `rotate_axis`.
void check_rotation(const Input& in, const YAML::Node& t, const std::string& tpath) {
  if (t["rotate_deg"].as<double>() != 0.0 && v3(t["rotate_axis"]).norm() == 0.0)
    in.ctx.fail(tpath + ".rotate_axis", in.in_node(tpath + ".rotate_axis"),
                "rotate_axis [0, 0, 0] has no direction, but rotate_deg is " + t["rotate_deg"].as<std::string>() +
                    "; give the axis to rotate about",
                {tpath + ".rotate_deg"});
}

/// Placed coordinates beyond kMaxCoordinate (a mesh in the wrong unit, a huge scale): refused
/// here, naming the vertex, rather than found by the renderer or the export.
void check_placed(const Input& in, const Positions& v, const std::string& path, const std::string& name) {
  for (size_t i = 0; i < v.size(); ++i)
    if (!(v[i].cwiseAbs().maxCoeff() <= kMaxCoordinate))
      in.ctx.fail(path + ".transform", in.in_node(path),
                  "object '" + name + "': vertex " + std::to_string(i + 1) + " lies at (" +
                      ccfr::format("{:g}, {:g}, {:g}", v[i].x(), v[i].y(), v[i].z()) +
                      ") once placed, beyond +-1e6 m, ccfr's bound on coordinates (check the mesh's unit and "
                      "transform.scale)");
}

void place(RawGeometry& g, const YAML::Node& t) {
  const double scale = t["scale"].as<double>();
  const Vec3 axis = v3(t["rotate_axis"]);
  const double ang = t["rotate_deg"].as<double>() * std::numbers::pi / 180.0;
  const Vec3 tr = v3(t["translate"]);
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (ang != 0.0 && axis.norm() > 0) R = Eigen::AngleAxisd(ang, axis.normalized()).toRotationMatrix();
  for (auto& v : g.v) v = R * (scale * v) + tr;
  g.shape.center = tr;
  g.shape.rotation = R;
  g.shape.radius *= scale;
  g.shape.half_height *= scale;
  g.shape.half_extent *= scale;
}

}  // namespace ccfr::io::scene
