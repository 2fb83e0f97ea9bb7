#include "scene_advice.hpp"

#include "ccfr/core/log.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

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
int ceil_count(double x) { return static_cast<int>(std::ceil(x * (1.0 - 1e-12))); }

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

}  // namespace ccfr::app
