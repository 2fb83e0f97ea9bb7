#include "scene_advice.hpp"

#include "ccfr/core/log.hpp"
#include "ccfr/geometry/aabb.hpp"
#include "ccfr/geometry/bvh.hpp"
#include "ccfr/geometry/distance.hpp"
#include "ccfr/geometry_exact/predicates.hpp"

#include <spdlog/spdlog.h>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace ccfr::app {

namespace {

/// Fastest speed (m/s) of the points `p0` under `m`: translation plus rotation about the axis.
double max_speed(const Motion& m, const Positions& x, Index begin, Index end, const std::vector<Index>* subset) {
  if (!m.moves()) return 0.0;
  const Vec3 axis = m.axis.norm() > 0 ? m.axis.normalized() : Vec3::UnitY();
  double arm = 0.0;
  auto visit = [&](Index v) {
    const Vec3 d = x[v] - m.center;
    arm = std::max(arm, (d - d.dot(axis) * axis).norm());
  };
  if (subset)
    for (Index local : *subset) visit(begin + local);
  else
    for (Index v = begin; v < end; ++v) visit(v);
  return m.velocity.norm() + std::abs(m.angular_velocity) * arm;
}

/// ceil that ignores rounding noise: 3 / (60 * 0.01) is 5, not 6.
int ceil_count(double x) {
  return static_cast<int>(std::min(std::ceil(x * (1.0 - 1e-12)), static_cast<double>(std::numeric_limits<int>::max())));
}

}  // namespace

std::vector<std::string> scene_advice(const Scene& scene) {
  std::vector<std::string> out;
  const Topology& topo = scene.topo;
  const SimulationParams& p = scene.params;
  const Positions& x = scene.state.x;
  const double r = p.contact.radius, xi = p.contact.offset;

  // Shortest edge of the deformable surfaces and solids: obstacles and rigid bodies never fold,
  // and strands (hair at ξ = 0.8 of a segment, docs/results.md) run clean with short segments.
  double shortest = std::numeric_limits<double>::infinity();
  Index shortest_object = -1;
  for (Index e = 0; e < topo.num_edges(); ++e) {
    const Index o = topo.edge_object[e];
    const ObjectKind k = topo.objects[o].kind;
    if (k != ObjectKind::cloth && k != ObjectKind::shell && k != ObjectKind::tet_solid) continue;
    const double len = (x[topo.edges[e][1]] - x[topo.edges[e][0]]).norm();
    if (len > 0 && len < shortest) shortest = len, shortest_object = o;
  }
  if (shortest_object >= 0 && xi > kMaxOffsetOverEdge * shortest * (1.0 + 1e-9))
    out.push_back(fmt::format(
        "contact.offset (xi) = {:.4g} is {:.2f} times the shortest edge of object '{}' ({:.4g}); above {:.2f} the "
        "pairs that start within xi of their mesh neighbours keep 90% of their rest distance as offset, so the "
        "surface resists compression and tight folds there, and the search range covers many neighbours (cost). "
        "Use xi <= {:.4g} or edges of at least {:.4g} (docs/choosing-parameters.md)",
        xi, xi / shortest, topo.objects[shortest_object].name, shortest, kMaxOffsetOverEdge,
        kMaxOffsetOverEdge * shortest, xi / kMaxOffsetOverEdge));

  // A step of more than r per substep: scripted vertices force the substep to be split (each piece
  // a full collision pass), dynamic ones are held back by the step bound and lag behind.
  const double dt = 1.0 / (p.time.fps * p.time.substeps);
  auto too_fast = [&](const std::string& object, const char* what, double speed, const std::string& effect) {
    if (speed * dt <= r) return;
    out.push_back(fmt::format(
        "object '{}': {} {:.4g} m/s covers {:.4g} per substep, more than r = {:.4g}; {}. Set time.substeps to at "
        "least {} or contact.radius to at least {:.4g} (docs/choosing-parameters.md)",
        object, what, speed, speed * dt, r, effect, ceil_count(speed / (p.time.fps * r)), speed * dt));
  };
  for (size_t oi = 0; oi < topo.objects.size() && oi < p.objects.size(); ++oi) {
    const ObjectInfo& o = topo.objects[oi];
    const ObjectParams& op = p.objects[oi];
    double scripted = o.kinematic() ? max_speed(op.motion, x, o.vertex_begin, o.vertex_end, nullptr) : 0.0;
    for (const PinGroup& g : op.pins)
      scripted = std::max(scripted, max_speed(g.motion, x, o.vertex_begin, o.vertex_end, &g.vertices));
    too_fast(o.name, "scripted motion up to", scripted,
             fmt::format("every substep is split into {} pieces, each a full collision pass",
                         ceil_count(scripted * dt / r)));
    if (!o.kinematic())
      too_fast(o.name, "initial velocity", op.initial_velocity.norm(),
               "the step bound makes extra outer iterations or holds the object back");
  }
  return out;
}

namespace {

/// The first pair of faces of objects a and b (positions x) that intersect or lie within xi:
/// {face of a, face of b, intersecting}; exact intersection, double distances.
struct FaceContact {
  Index fa = -1, fb = -1;
  bool intersect = false;
};

std::optional<FaceContact> face_contact(const Topology& topo, const Positions& x, const ObjectInfo& a,
                                        const ObjectInfo& b, double xi) {
  // Boxes grown by xi/2: faces within xi of each other have overlapping boxes.
  auto box = [&](Index f) {
    const Vec3i& t = topo.faces[f];
    AABB bx = AABB::of(x[t[0]], x[t[1]], x[t[2]]);
    bx.inflate(0.5 * xi);
    return bx;
  };
  // The BVH over the object with more faces, queried with the other's.
  const bool swap = (a.face_end - a.face_begin) < (b.face_end - b.face_begin);
  const ObjectInfo &big = swap ? b : a, &small = swap ? a : b;
  std::vector<AABB> boxes;
  for (Index f = big.face_begin; f < big.face_end; ++f) boxes.push_back(box(f));
  if (boxes.empty() || small.face_end == small.face_begin) return std::nullopt;
  Bvh bvh;
  bvh.build(boxes, 4);
  std::vector<Index> hits;
  const double xi_sq = xi * xi;
  std::optional<FaceContact> within;
  for (Index g = small.face_begin; g < small.face_end; ++g) {
    hits.clear();
    bvh.query(box(g), hits);
    const Vec3i& tg = topo.faces[g];
    for (const Index h : hits) {
      const Index f = big.face_begin + h;
      const Vec3i& tf = topo.faces[f];
      const FaceContact c{swap ? g : f, swap ? f : g, false};
      if (exact::triangles_intersect(x[tf[0]], x[tf[1]], x[tf[2]], x[tg[0]], x[tg[1]], x[tg[2]]))
        return FaceContact{c.fa, c.fb, true};
      if (within) continue;
      // Distance of two disjoint triangles: attained at a vertex-face or an edge-edge pair.
      double d2 = std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        d2 = std::min(d2, point_triangle(x[tf[k]], x[tg[0]], x[tg[1]], x[tg[2]]).distance_sq);
        d2 = std::min(d2, point_triangle(x[tg[k]], x[tf[0]], x[tf[1]], x[tf[2]]).distance_sq);
        for (int l = 0; l < 3; ++l)
          d2 = std::min(d2, edge_edge(x[tf[k]], x[tf[(k + 1) % 3]], x[tg[l]], x[tg[(l + 1) % 3]]).distance_sq);
      }
      if (d2 < xi_sq) within = c;
    }
  }
  return within;
}

}  // namespace

std::vector<std::string> scripted_contacts(const Scene& scene, int max_samples) {
  std::vector<std::string> out;
  const Topology& topo = scene.topo;
  const SimulationParams& p = scene.params;
  const double xi = p.contact.offset;
  std::vector<Index> scripted;  // obstacles with faces: their motion is known in advance
  for (size_t o = 0; o < topo.objects.size() && o < p.objects.size(); ++o)
    if (topo.objects[o].kind == ObjectKind::obstacle && topo.objects[o].face_end > topo.objects[o].face_begin)
      scripted.push_back(static_cast<Index>(o));
  if (scripted.size() < 2 || !(xi > 0.0)) return out;
  bool any_moves = false;
  for (const Index o : scripted) any_moves = any_moves || p.objects[o].motion.moves();

  const int frames = std::max(0, p.time.frames);
  const int samples = any_moves ? std::max(2, std::min(max_samples, frames + 1)) : 1;
  Positions x = scene.state.x;
  std::vector<std::uint8_t> reported(scripted.size() * scripted.size(), 0);
  for (int s = 0; s < samples; ++s) {
    const int frame =
        samples == 1 ? 0 : static_cast<int>(std::llround(static_cast<double>(s) * frames / (samples - 1)));
    const double t = p.time.fps > 0 ? frame / p.time.fps : 0.0;
    std::vector<AABB> box(scripted.size());
    for (size_t k = 0; k < scripted.size(); ++k) {
      const ObjectInfo& o = topo.objects[scripted[k]];
      const Motion& m = p.objects[scripted[k]].motion;
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v) {
        if (s > 0 && m.moves())
          x[v] = m.animation ? m.animation->at(v - o.vertex_begin, t) : m.apply(scene.state.rest[v], t);
        box[k].expand(x[v]);
      }
      box[k].inflate(0.5 * xi);
    }
    for (size_t i = 0; i < scripted.size(); ++i)
      for (size_t j = i + 1; j < scripted.size(); ++j) {
        // Two static obstacles keep their frame-0 relation, which the audit's frame-0 rules decide.
        if (!p.objects[scripted[i]].motion.moves() && !p.objects[scripted[j]].motion.moves()) continue;
        if (reported[i * scripted.size() + j] || !box[i].overlaps(box[j])) continue;
        const ObjectInfo &a = topo.objects[scripted[i]], &b = topo.objects[scripted[j]];
        const auto c = face_contact(topo, x, a, b, xi);
        if (!c) continue;
        reported[i * scripted.size() + j] = 1;
        out.push_back(fmt::format(
            "obstacles '{}' and '{}' {} at frame {} (t = {:.4g} s; face {} of '{}' and face {} of '{}', {}): both are "
            "scripted, so no solver can keep them apart, and `ccfr audit` reports their pairs as a scene error, not "
            "as the method's failure. Move them apart or change their motion",
            a.name, b.name, c->intersect ? "intersect" : "come closer than xi", frame, t, c->fa - a.face_begin, a.name,
            c->fb - b.face_begin, b.name, c->intersect ? "intersecting" : fmt::format("closer than xi = {:.4g}", xi)));
      }
  }
  return out;
}

}  // namespace ccfr::app
