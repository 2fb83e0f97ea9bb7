#include "ccfr/core/topology.hpp"

#include <algorithm>
#include <array>
#include <map>
#include <stdexcept>

namespace ccfr {

namespace {
constexpr std::array<std::pair<ObjectKind, std::string_view>, 7> kKindNames{{
    {ObjectKind::cloth, "cloth"},
    {ObjectKind::shell, "shell"},
    {ObjectKind::tet_solid, "tet_solid"},
    {ObjectKind::strand, "strand"},
    {ObjectKind::particles, "particles"},
    {ObjectKind::obstacle, "obstacle"},
    {ObjectKind::rigid, "rigid"},
}};
}  // namespace

std::string_view to_string(ObjectKind kind) {
  for (const auto& [k, n] : kKindNames)
    if (k == kind) return n;
  return "unknown";
}

std::optional<ObjectKind> object_kind_from_string(std::string_view name) {
  for (const auto& [k, n] : kKindNames)
    if (n == name) return k;
  return std::nullopt;
}

const std::vector<std::string_view>& object_kind_names() {
  static const std::vector<std::string_view> names = [] {
    std::vector<std::string_view> v;
    for (const auto& kn : kKindNames) v.push_back(kn.second);
    return v;
  }();
  return names;
}

const ObjectInfo* Topology::find_object(std::string_view name) const {
  for (const auto& o : objects)
    if (o.name == name) return &o;
  return nullptr;
}

std::vector<Vec3i> tet_boundary(const std::vector<Vec4i>& tets) {
  // Outward faces of a positively oriented tet (a,b,c,d): (b,c,d), (a,d,c), (a,b,d), (a,c,b).
  static constexpr int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  std::map<std::array<Index, 3>, std::pair<int, Vec3i>> count;
  for (const auto& t : tets) {
    for (const auto& f : kFace) {
      Vec3i tri(t[f[0]], t[f[1]], t[f[2]]);
      std::array<Index, 3> key{tri[0], tri[1], tri[2]};
      std::sort(key.begin(), key.end());
      auto& slot = count[key];
      ++slot.first;
      slot.second = tri;
    }
  }
  std::vector<Vec3i> out;
  for (const auto& [key, c] : count)
    if (c.first == 1) out.push_back(c.second);
  return out;
}

Index TopologyBuilder::add_object(std::string name, ObjectKind kind, Index num_vertices,
                                  const std::vector<Vec3i>& faces, const std::vector<Vec4i>& tets,
                                  const std::vector<std::vector<Index>>& polylines) {
  const Index base = static_cast<Index>(topo_.vertex_object.size());
  const Index obj_id = static_cast<Index>(topo_.objects.size());
  ObjectInfo info;
  info.name = std::move(name);
  info.kind = kind;
  info.vertex_begin = base;
  info.vertex_end = base + num_vertices;
  auto check = [&](Index i) {
    if (i < 0 || i >= num_vertices)
      throw std::invalid_argument("object '" + info.name + "': vertex index " + std::to_string(i) +
                                  " out of range [0, " + std::to_string(num_vertices) + ")");
    return i + base;
  };

  info.tet_begin = static_cast<Index>(topo_.tets.size());
  for (const auto& t : tets) topo_.tets.emplace_back(check(t[0]), check(t[1]), check(t[2]), check(t[3]));
  info.tet_end = static_cast<Index>(topo_.tets.size());

  const std::vector<Vec3i> surface = (kind == ObjectKind::tet_solid && faces.empty()) ? tet_boundary(tets) : faces;
  info.face_begin = static_cast<Index>(topo_.faces.size());
  for (const auto& f : surface) {
    topo_.faces.emplace_back(check(f[0]), check(f[1]), check(f[2]));
    topo_.face_object.push_back(obj_id);
  }
  info.face_end = static_cast<Index>(topo_.faces.size());

  info.polyline_begin = static_cast<Index>(polylines_.size());
  for (const auto& pl : polylines) {
    std::vector<Index> g;
    g.reserve(pl.size());
    for (Index i : pl) g.push_back(check(i));
    polylines_.push_back(std::move(g));
  }
  info.polyline_end = static_cast<Index>(polylines_.size());

  topo_.vertex_object.insert(topo_.vertex_object.end(), static_cast<size_t>(num_vertices), obj_id);
  topo_.objects.push_back(std::move(info));
  return obj_id;
}

Topology TopologyBuilder::finish() {
  Topology t = std::move(topo_);
  topo_ = Topology{};
  const Index nv = t.num_vertices();

  // Unique face edges first (sorted for determinism), then strand segments.
  struct EdgeRef {
    Index a, b, face, slot;
  };
  std::vector<EdgeRef> refs;
  refs.reserve(t.faces.size() * 3);
  for (Index f = 0; f < t.num_faces(); ++f)
    for (Index k = 0; k < 3; ++k) {
      Index a = t.faces[f][k], b = t.faces[f][(k + 1) % 3];
      refs.push_back({std::min(a, b), std::max(a, b), f, k});
    }
  std::sort(refs.begin(), refs.end(), [](const EdgeRef& l, const EdgeRef& r) {
    return l.a != r.a ? l.a < r.a : (l.b != r.b ? l.b < r.b : l.face < r.face);
  });
  t.face_edges.assign(t.faces.size(), Vec3i::Constant(-1));
  for (size_t i = 0; i < refs.size(); ++i) {
    if (i == 0 || refs[i].a != refs[i - 1].a || refs[i].b != refs[i - 1].b) {
      t.edges.emplace_back(refs[i].a, refs[i].b);
      t.edge_object.push_back(t.vertex_object[refs[i].a]);
    }
    t.face_edges[refs[i].face][refs[i].slot] = static_cast<Index>(t.edges.size()) - 1;
  }
  for (const auto& pl : polylines_) {
    t.polylines.indices.insert(t.polylines.indices.end(), pl.begin(), pl.end());
    t.polylines.row_start.push_back(static_cast<Index>(t.polylines.indices.size()));
    for (size_t i = 1; i < pl.size(); ++i) {
      t.edges.emplace_back(std::min(pl[i - 1], pl[i]), std::max(pl[i - 1], pl[i]));
      t.edge_object.push_back(t.vertex_object[pl[i]]);
    }
  }
  polylines_.clear();
  t.vertex_faces = Csr::incidence<3>(nv, t.faces);
  t.vertex_edges = Csr::incidence<2>(nv, t.edges);
  return t;
}

}  // namespace ccfr
