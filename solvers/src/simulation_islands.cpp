// contact.momentum's free islands: the bodies one substep's contacts join, with nothing pinned,
// scripted or fixed among them, get back the linear and angular momentum the projection took
// (docs/feasibility.md, "A free island keeps its momentum").
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/geometry/aabb.hpp"
#include "ccfr/solvers/rigid_bodies.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "ccfr/solvers/step_bound.hpp"

namespace ccfr {

Index Simulation::island_of(Index o) {
  while (island_parent_[o] != o) o = island_parent_[o] = island_parent_[island_parent_[o]];
  return o;
}

void Simulation::start_islands() {
  const auto& topo = scene_.topo;
  const auto& st = scene_.state;
  // contact.momentum under the region-projection solvers (follow_steps_), as the group carry: the
  // baselines keep their own response.
  islands_on_ = follow_steps_ && analytic_obstacles_.empty() && contact_->detected_contacts();
  if (!islands_on_) return;
  const auto no = static_cast<Index>(topo.objects.size());
  island_parent_.resize(static_cast<size_t>(no));
  std::iota(island_parent_.begin(), island_parent_.end(), Index{0});
  island_fixed_.assign(static_cast<size_t>(no), 0);
  if (object_core_.size() != static_cast<size_t>(no)) {
    // A rigid body's momentum counts its core, the mass at its centre that no vertex carries.
    object_core_.assign(static_cast<size_t>(no), 0.0);
    const RigidBodies bodies(topo, st, &scene_.params);
    for (Index o = 0; o < no; ++o) {
      const auto& obj = topo.objects[o];
      const Index b = obj.kind == ObjectKind::rigid && obj.num_vertices() > 0 ? bodies.body_of(obj.vertex_begin) : -1;
      if (b >= 0) object_core_[static_cast<size_t>(o)] = bodies.core_of(b);
    }
  }
  bool any_free = false;
  for (Index o = 0; o < no; ++o) {
    const auto& obj = topo.objects[o];
    // Bodies only: strands and particles are many pieces whose contacts move few of them.
    bool fixed = !(obj.kind == ObjectKind::tet_solid || obj.kind == ObjectKind::cloth ||
                   obj.kind == ObjectKind::shell || obj.kind == ObjectKind::rigid);
    for (Index v = obj.vertex_begin; v < obj.vertex_end && !fixed; ++v) fixed = !(st.inv_mass[v] > 0.0);
    island_fixed_[static_cast<size_t>(o)] = fixed ? 1 : 0;
    any_free = any_free || !fixed;
  }
  islands_on_ = any_free;
}

void Simulation::join_islands() {
  if (!islands_on_) return;
  const auto& vo = scene_.topo.vertex_object;
  for (const ContactPair& c : *contact_->detected_contacts()) {
    const Index o0 = vo[c.v[0]];
    for (int k = 1; k < c.size(); ++k) {
      const Index ok = vo[c.v[k]];
      if (ok == o0) continue;
      const Index a = island_of(o0), b = island_of(ok);
      if (a == b) continue;
      island_parent_[b] = a;
      island_fixed_[a] |= island_fixed_[b];
    }
  }
}

namespace {
/// Cross-product matrix [a]×: [a]× b = a × b.
Eigen::Matrix3d cross_matrix(const Vec3& a) {
  Eigen::Matrix3d m;
  m << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return m;
}
}  // namespace

bool Simulation::island_clear(Index root, const AABB& swept, const std::vector<AABB>& box, double gap) {
  if (!swept.valid()) return false;
  for (Index p = 0; p < static_cast<Index>(box.size()); ++p)
    if (island_of(p) != root && box[p].valid() && !swept.apart(box[p], gap)) return false;
  return true;
}

Index Simulation::restore_island_momentum() {
  if (!islands_on_) return 0;
  const auto& topo = scene_.topo;
  const auto& st = scene_.state;
  const auto& cp = scene_.params.contact;
  const auto no = static_cast<Index>(topo.objects.size());
  std::vector<AABB> box(static_cast<size_t>(no));
  std::vector<std::vector<Index>> members(static_cast<size_t>(no));  // per free root: its objects
  for (Index o = 0; o < no; ++o) {
    const auto& obj = topo.objects[o];
    for (Index v = obj.vertex_begin; v < obj.vertex_end; ++v) box[o].expand(anchor_[v]);
    const Index root = island_of(o);
    if (!island_fixed_[root]) members[root].push_back(o);
  }
  auto each_vertex = [&](Index root, auto&& f) {
    for (const Index o : members[root])
      for (Index v = topo.objects[o].vertex_begin; v < topo.objects[o].vertex_end; ++v) f(v);
  };
  // Masses as the material sweeps weigh them (every vertex of a free island has inverse mass > 0).
  auto mass_of = [&](Index v) { return 1.0 / st.inv_mass[v]; };
  // Every point mass of the island: f(m, x, y, x_prev) per vertex (x its anchor, y its material
  // solve), and per rigid body with a core the core at the body's centre (its vertices' masses
  // are centred there, so the core moves with that centre).
  auto each_point = [&](Index root, auto&& f) {
    for (const Index o : members[root]) {
      const auto& obj = topo.objects[o];
      double m = 0.0;
      Vec3 cx = Vec3::Zero(), cy = Vec3::Zero(), cprev = Vec3::Zero();
      for (Index v = obj.vertex_begin; v < obj.vertex_end; ++v) {
        const double mv = mass_of(v);
        f(mv, anchor_[v], material_solved_[v], st.x_prev[v]);
        m += mv, cx += mv * anchor_[v], cy += mv * material_solved_[v], cprev += mv * st.x_prev[v];
      }
      const double core = object_core_[static_cast<size_t>(o)];
      if (core > 0.0 && m > 0.0) f(core, Vec3(cx / m), Vec3(cy / m), Vec3(cprev / m));
    }
  };
  auto island_box = [&](Index root) {
    AABB b;
    for (const Index o : members[root]) b.expand(box[o]);
    return b;
  };
  const double r = cp.radius, gap = cp.offset + cp.repulsion_range;
  Index moved = 0;
  for (Index first = 0; first < no; ++first) {
    // Islands in the order of their lowest object: the order the contacts joined them in does not matter.
    const Index root = island_of(first);
    if (members[root].empty() || members[root].front() != first) continue;
    // Linear momentum: the island's mass-weighted shortfall behind the material solve y.
    double mass = 0.0;
    Vec3 taken = Vec3::Zero();
    each_point(root, [&](double m, const Vec3& x, const Vec3& y, const Vec3&) { mass += m, taken += m * (x - y); });
    if (!(mass > 0.0)) continue;
    bool changed = false;
    const Vec3 t = -taken / mass;
    // Nothing taken (rounding), or a blow-up rather than a motion (cut as a long step is).
    if (t.allFinite() && t.norm() > 1e-12 * r && t.norm() <= kLongStepMost * r) {
      // Translated as one, the island keeps every distance within it along the way; against every
      // other object its box swept along t must stay more than ξ + δ away.
      AABB swept = island_box(root);
      swept.expand(AABB{swept.lo + t, swept.hi + t});
      if (island_clear(root, swept, box, gap)) {
        each_vertex(root, [&](Index v) { anchor_[v] += t; });
        for (const Index o : members[root])
          if (box[o].valid()) box[o].lo += t, box[o].hi += t;
        changed = true;
      }
    }
    // Angular momentum about the island's centre c: L = Σ m (x - c) × (x - x_prev) per dt, against
    // the material solve's about its own centre (c itself once the shift is made). A turn θ about c
    // changes it by A θ to first order, A = -Σ m [p]×[q]× with p = x_prev - c, q = x - c (the
    // inertia tensor when the step is small); two Newton steps with A's pseudo-inverse (directions
    // of almost no inertia are not turned), together moving no vertex more than r, nor by more
    // than kMostTurn radians.
    Vec3 c = Vec3::Zero(), cy = Vec3::Zero();
    each_point(root, [&](double m, const Vec3& x, const Vec3& y, const Vec3&) { c += m * x, cy += m * y; });
    c /= mass, cy /= mass;
    Vec3 goal = Vec3::Zero();
    double reach = 0.0;
    each_point(root, [&](double m, const Vec3& x, const Vec3& y, const Vec3& prev) {
      goal += m * (y - cy).cross(y - prev);
      reach = std::max(reach, (x - c).norm());
    });
    constexpr double kMostTurn = 0.5;
    double arc_left = r, angle_left = kMostTurn;  // the turns' budget for this substep
    for (int newton = 0; newton < 2; ++newton) {
      Vec3 now = Vec3::Zero();
      Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
      each_point(root, [&](double m, const Vec3& x, const Vec3&, const Vec3& prev) {
        const Vec3 q = x - c;
        now += m * q.cross(x - prev);
        a.noalias() -= m * cross_matrix(prev - c) * cross_matrix(q);
      });
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(a, Eigen::ComputeFullU | Eigen::ComputeFullV);
      const Vec3 sigma = svd.singularValues();
      Vec3 inv = Vec3::Zero();
      for (int k = 0; k < 3; ++k) inv[k] = sigma[k] > 1e-6 * sigma[0] ? 1.0 / sigma[k] : 0.0;
      const Vec3 theta = svd.matrixV() * inv.asDiagonal() * svd.matrixU().transpose() * (goal - now);
      // No turn left; else within the budget (a first-order step is not trusted beyond it).
      if (!theta.allFinite() || !(theta.norm() * reach > 1e-12 * r)) break;
      const double angle = std::min({theta.norm(), arc_left / reach, angle_left});
      if (!(angle * reach > 1e-12 * r)) break;
      arc_left -= angle * reach, angle_left -= angle;
      // Every point of the island moves along an arc no longer than angle · reach.
      AABB swept = island_box(root);
      swept.inflate(angle * reach);
      if (!island_clear(root, swept, box, gap)) break;
      const Eigen::Matrix3d rot = Eigen::AngleAxisd(angle, theta.normalized()).toRotationMatrix();
      each_vertex(root, [&](Index v) { anchor_[v] = c + rot * (anchor_[v] - c); });
      for (const Index o : members[root]) {
        box[o] = AABB{};
        for (Index v = topo.objects[o].vertex_begin; v < topo.objects[o].vertex_end; ++v) box[o].expand(anchor_[v]);
      }
      changed = true;
    }
    moved += changed ? 1 : 0;
  }
  return moved;
}

}  // namespace ccfr
