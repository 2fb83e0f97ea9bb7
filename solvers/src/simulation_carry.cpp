// The carry before detection: an object that touches nothing is moved along its rigid motion
// (a body) or its step (a grain under contact.momentum) before the regions are built
// (docs/architecture.md, "Why the carry is safe").
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/aabb.hpp"
#include "ccfr/solvers/polar_decomposition.hpp"
#include "ccfr/solvers/simulation.hpp"
#include "ccfr/solvers/step_bound.hpp"

namespace ccfr {

namespace {
/// A movable body's best rigid motion from its anchors to the material solve: the mass-weighted
/// centres' shift (the mass-weighted centre carries the momentum) and the polar rotation of A_pq
/// (Müller et al. 2005) about the anchors' centre c. `body` is false for any other object.
struct BodyMotion {
  bool body = false;
  Vec3 c = Vec3::Zero(), shift = Vec3::Zero(), axis = Vec3::UnitX();
  double angle = 0.0, reach = 0.0;  // reach: the farthest anchor from c (m)
};

/// The boxes of object o's triangles at `x`.
std::vector<AABB> face_boxes(const Topology& topo, Index o, const Positions& x) {
  const auto& obj = topo.objects[o];
  std::vector<AABB> out;
  out.reserve(static_cast<size_t>(obj.face_end - obj.face_begin));
  for (Index t = obj.face_begin; t < obj.face_end; ++t) {
    const Vec3i& f = topo.faces[t];
    out.push_back(AABB::of(x[f[0]], x[f[1]], x[f[2]]));
  }
  return out;
}

std::vector<BodyMotion> body_motions(const Topology& topo, const SimState& st, const Positions& anchor,
                                     const Positions& solved, const std::vector<AABB>& box) {
  std::vector<BodyMotion> motion(topo.objects.size());
  parallel_for(
      static_cast<Index>(topo.objects.size()),
      [&](Index b, Index e) {
        for (Index o = b; o < e; ++o) {
          const auto& obj = topo.objects[o];
          // Bodies only: a particle cloud or a strand set is many independent pieces, not one shape.
          const bool body =
              obj.kind == ObjectKind::tet_solid || obj.kind == ObjectKind::cloth || obj.kind == ObjectKind::shell;
          if (!body || obj.num_vertices() < 2 || !box[o].valid()) continue;
          bool movable = true;  // not pinned, scripted, or fixed for this pass (time.continuation: held_back)
          for (Index v = obj.vertex_begin; v < obj.vertex_end && movable; ++v) movable = st.inv_mass[v] > 0.0;
          if (!movable) continue;
          BodyMotion& m = motion[o];
          double total = 0.0;
          Vec3 c1 = Vec3::Zero();
          for (Index v = obj.vertex_begin; v < obj.vertex_end; ++v) {
            const double mass = 1.0 / st.inv_mass[v];
            total += mass;
            m.c += mass * anchor[v];
            c1 += mass * solved[v];
          }
          m.c /= total;
          c1 /= total;
          Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
          for (Index v = obj.vertex_begin; v < obj.vertex_end; ++v) {
            const Vec3 q = anchor[v] - m.c;
            a.noalias() += (1.0 / st.inv_mass[v]) * (solved[v] - c1) * q.transpose();
            m.reach = std::max(m.reach, q.norm());
          }
          const Eigen::AngleAxisd turn(xpbd::polar_rotation(a));
          m.shift = c1 - m.c;
          m.angle = std::isfinite(turn.angle()) ? turn.angle() : 0.0;
          m.axis = turn.axis();
          m.body = m.shift.allFinite() && std::isfinite(m.reach);
        }
      },
      1);
  return motion;
}
}  // namespace

Index Simulation::carry_isolated_objects() {
  const auto& topo = scene_.topo;
  const auto& st = scene_.state;
  const auto& cp = scene_.params.contact;
  const double r = cp.radius;
  const size_t no = topo.objects.size();
  // Object boxes at the anchors.
  std::vector<AABB> box(no);
  parallel_for(
      static_cast<Index>(no),
      [&](Index b, Index e) {
        for (Index o = b; o < e; ++o)
          for (Index v = topo.objects[o].vertex_begin; v < topo.objects[o].vertex_end; ++v) box[o].expand(anchor_[v]);
      },
      1);
  const std::vector<BodyMotion> motion = body_motions(topo, st, anchor_, material_solved_, box);
  // Two ways to be isolated. Swept: the body's box swept along its whole translation, grown by
  // the turn it is carried (at most r per vertex), stays more than ξ + δ from every other object's
  // box, each body's swept the same way: the translation is carried in full, and detection then
  // starts from the carried anchors. Near: its box is more than 4r + ξ + δ from every other
  // (every vertex ends a pass within 2r of its anchor, r carried, r solved): carried at most r.
  // A scripted vertex reaches its target in the substep's first pass, wherever the regions are:
  // its object's box covers the target too. Analytic obstacles (contact.analytic_obstacles) reach
  // beyond their mesh's box, so with them only the near rule carries.
  std::vector<AABB> swept(box);
  for (const Index v : kinematic_)
    swept[static_cast<size_t>(topo.vertex_object[v])].expand(st.x[v] + kinematic_step_[v]);
  const bool sweeps = analytic_obstacles_.empty();
  // A grain may be carried its step (carry_free_grains): under contact.momentum or the free islands.
  const bool grains_follow = follow_steps_ || free_islands_;
  for (size_t o = 0; o < no; ++o) {
    if (grains_follow && topo.objects[o].kind == ObjectKind::particles)
      for (Index v = topo.objects[o].vertex_begin; v < topo.objects[o].vertex_end; ++v)
        if (st.inv_mass[v] > 0.0 && material_solved_[v].allFinite()) swept[o].expand(material_solved_[v]);
    if (!motion[o].body) continue;
    AABB moved = box[o];
    moved.lo += motion[o].shift;
    moved.hi += motion[o].shift;
    swept[o].expand(moved);
    swept[o].inflate(std::min(motion[o].angle * motion[o].reach, r));
  }
  const double near_gap = 4.0 * r + cp.offset + cp.repulsion_range, swept_gap = cp.offset + cp.repulsion_range;
  // Where two swept boxes meet, the swept one's triangles against the other's at its anchors, for
  // an other that stays where it is in this loop: a mesh object (its collision primitives are its
  // triangles) that is not a body (never carried here) and has no scripted vertex that moves in
  // this substep (a pin stays at its anchor).
  std::vector<std::uint8_t> still_mesh(no, 0);
  for (size_t p = 0; p < no; ++p) {
    const auto& obj = topo.objects[p];
    still_mesh[p] = obj.kind != ObjectKind::strand && obj.kind != ObjectKind::particles && !motion[p].body &&
                    obj.face_end > obj.face_begin;
  }
  for (const Index v : kinematic_)
    if (kinematic_step_[v] != Vec3::Zero()) still_mesh[static_cast<size_t>(topo.vertex_object[v])] = 0;
  std::vector<AABB> scratch;
  auto triangles_apart = [&](size_t o, size_t p) {
    const BodyMotion& m = motion[o];
    std::vector<AABB> moving = face_boxes(topo, static_cast<Index>(o), anchor_);
    for (AABB& b : moving) {
      b.expand(AABB{b.lo + m.shift, b.hi + m.shift});
      b.inflate(std::min(m.angle * m.reach, r));
    }
    return all_apart(moving, face_boxes(topo, static_cast<Index>(p), anchor_), swept_gap, scratch);
  };
  Index carried = 0;
  carry_capped_.assign(anchor_.size(), 0);
  std::vector<std::uint8_t> carried_object(no, 0);
  for (size_t o = 0; o < no; ++o) {
    const BodyMotion& m = motion[o];
    if (!m.body) continue;
    bool isolated_swept = sweeps, isolated_near = true;
    for (size_t p = 0; p < no && (isolated_swept || isolated_near); ++p) {
      if (p == o || topo.objects[p].num_vertices() == 0) continue;
      isolated_swept =
          isolated_swept && (swept[o].apart(swept[p], swept_gap) || (still_mesh[p] && triangles_apart(o, p)));
      isolated_near = isolated_near && box[o].apart(box[p], near_gap);
    }
    const double turn_reach = m.angle * m.reach;  // |R q - q| <= angle |q|
    if (!(isolated_swept || isolated_near) || !(m.shift.norm() + turn_reach > 1e-12 * r) || !std::isfinite(turn_reach))
      continue;
    // The share of the translation and of the turn carried: no vertex farther than r along the
    // turn, nor (near only) than r in all. A translation longer than kLongStepMost r is a
    // blow-up, not a motion: cut there, as a long step is.
    double f_shift = std::min(1.0, kLongStepMost * r / m.shift.norm()), f_turn = std::min(1.0, r / turn_reach);
    if (!isolated_swept) f_shift = f_turn = std::min(1.0, r / (m.shift.norm() + turn_reach));
    const auto& obj = topo.objects[o];
    if (turn_reach <= 1e-12 * r) {
      // A translation: added exactly, so pair distances change by rounding of the sums only.
      const Vec3 t = f_shift * m.shift;
      for (Index v = obj.vertex_begin; v < obj.vertex_end; ++v) anchor_[v] += t;
    } else {
      const Eigen::Matrix3d rot = Eigen::AngleAxisd(f_turn * m.angle, m.axis).toRotationMatrix();
      const Vec3 to = m.c + f_shift * m.shift;
      for (Index v = obj.vertex_begin; v < obj.vertex_end; ++v) anchor_[v] = to + rot * (anchor_[v] - m.c);
    }
    ++carried;
    carried_object[o] = 1;
    // Carried only part of the way: the rest of its rigid motion waits for the next pass, where
    // it is carried again, rather than being solved against regions that would hold parts back.
    if (f_shift < 1.0 || f_turn < 1.0)
      for (Index v = obj.vertex_begin; v < obj.vertex_end; ++v) carry_capped_[v] = 1;
  }
  if (free_islands_ && sweeps) carried += carry_free_groups(box, swept, carried_object);
  // A grain whose box swept along its whole step meets nothing is carried that step, as a body in
  // free flight is: the paper's step bound of r a pass (its Alg. 1, line 16; kept with
  // contact.free_islands and contact.momentum false) held a grain falling off a floor's edge to
  // r a pass, 15 passes a substep at 16 m/s.
  if (grains_follow && sweeps)
    for (size_t o = 0; o < no; ++o)
      if (topo.objects[o].kind == ObjectKind::particles) carried += carry_free_grains(o, swept, swept_gap);
  return carried;
}

Index Simulation::carry_free_groups(const std::vector<AABB>& box, std::vector<AABB>& swept,
                                    const std::vector<std::uint8_t>& carried_object) {
  const auto& topo = scene_.topo;
  const auto& st = scene_.state;
  const auto& cp = scene_.params.contact;
  const double r = cp.radius, near_gap = 4.0 * r + cp.offset + cp.repulsion_range;
  const auto no = static_cast<Index>(topo.objects.size());
  // Groups: objects whose anchor boxes come within 4r + ξ + δ of one another (union-find).
  std::vector<Index> parent(static_cast<size_t>(no));
  std::iota(parent.begin(), parent.end(), Index{0});
  auto root_of = [&](Index o) {
    while (parent[o] != o) o = parent[o] = parent[parent[o]];
    return o;
  };
  for (Index o = 0; o < no; ++o)
    for (Index p = o + 1; p < no; ++p)
      if (box[o].valid() && box[p].valid() && !box[o].apart(box[p], near_gap)) parent[root_of(p)] = root_of(o);
  // A group is carried when it has two bodies or more, every one a movable tet solid, cloth or
  // shell not carried on its own: its mass-weighted translation toward the material solve.
  std::vector<std::uint8_t> fixed(static_cast<size_t>(no), 0);
  std::vector<Index> size(static_cast<size_t>(no), 0);
  std::vector<double> mass(static_cast<size_t>(no), 0.0);
  std::vector<Vec3> moment(static_cast<size_t>(no), Vec3::Zero());
  for (Index o = 0; o < no; ++o) {
    const auto& obj = topo.objects[o];
    if (obj.num_vertices() == 0) continue;
    const Index g = root_of(o);
    ++size[g];
    const bool body =
        obj.kind == ObjectKind::tet_solid || obj.kind == ObjectKind::cloth || obj.kind == ObjectKind::shell;
    bool free = body && !carried_object[o];
    for (Index v = obj.vertex_begin; v < obj.vertex_end && free; ++v) {
      free = st.inv_mass[v] > 0.0 && material_solved_[v].allFinite();
      if (!free) break;
      const double m = 1.0 / st.inv_mass[v];
      mass[g] += m;
      moment[g] += m * (material_solved_[v] - anchor_[v]);
    }
    if (!free) fixed[g] = 1;
  }
  Index carried = 0;
  for (Index g = 0; g < no; ++g) {
    if (root_of(g) != g || fixed[g] || size[g] < 2 || !(mass[g] > 0.0)) continue;
    const Vec3 shift = moment[g] / mass[g];
    if (!shift.allFinite() || !(shift.norm() > 1e-12 * r)) continue;
    const double f = std::min(1.0, kLongStepMost * r / shift.norm());
    const Vec3 t = f * shift;
    // Translated as one, the group keeps every distance within it; its box swept along t must
    // stay more than ξ + δ from every other object's, swept along its own carry or script.
    AABB group;
    for (Index o = 0; o < no; ++o)
      if (root_of(o) == g && box[o].valid()) group.expand(box[o]);
    AABB moved = group;
    moved.lo += t, moved.hi += t;
    group.expand(moved);
    bool clear = true;
    for (Index p = 0; p < no && clear; ++p)
      if (root_of(p) != g && topo.objects[p].num_vertices() > 0)
        clear = group.apart(swept[p], cp.offset + cp.repulsion_range);
    if (!clear) continue;
    for (Index o = 0; o < no; ++o) {
      if (root_of(o) != g) continue;
      const auto& obj = topo.objects[o];
      for (Index v = obj.vertex_begin; v < obj.vertex_end; ++v) {
        anchor_[v] += t;
        if (f < 1.0) carry_capped_[v] = 1;
      }
      // Later groups and grains are checked against where this one went.
      if (box[o].valid()) swept[o].expand(AABB{box[o].lo + t, box[o].hi + t});
      ++carried;
    }
  }
  return carried;
}

Index Simulation::carry_free_grains(size_t o, const std::vector<AABB>& swept, double gap) {
  const auto& topo = scene_.topo;
  const auto& st = scene_.state;
  const double r = scene_.params.contact.radius;
  const auto& obj = topo.objects[o];
  // Each grain's box swept along its step to the material solve (a fixed grain's is its anchor).
  const Index vb = obj.vertex_begin, n = obj.num_vertices();
  std::vector<AABB> grain(static_cast<size_t>(n));
  std::vector<Index> fast;
  for (Index i = 0; i < n; ++i) {
    const Index v = vb + i;
    grain[i].expand(anchor_[v]);
    if (!(st.inv_mass[v] > 0.0)) continue;
    const Vec3 step = material_solved_[v] - anchor_[v];
    if (!step.allFinite()) continue;
    grain[i].expand(material_solved_[v]);
    if (step.norm() > r) fast.push_back(i);  // a step within r needs no carry: one pass covers it
  }
  if (fast.empty()) return 0;
  // The slow grains (boxes at most r wide) and the fast ones, each in the order of their boxes'
  // lower x, to find by bisection those a box can meet: a box within the gap of [lo, hi] has its
  // lower x in [lo - widest - gap, hi + gap], widest taken over its own list (one long step does
  // not widen the search among the many short ones).
  std::vector<Index> slow;
  slow.reserve(static_cast<size_t>(n) - fast.size());
  for (Index i = 0, k = 0; i < n; ++i)
    if (k < static_cast<Index>(fast.size()) && fast[static_cast<size_t>(k)] == i)
      ++k;
    else
      slow.push_back(i);
  std::vector<Index> fast_order = fast;
  auto by_lower_x = [&](Index a, Index b) { return grain[a].lo.x() < grain[b].lo.x(); };
  std::sort(slow.begin(), slow.end(), by_lower_x);
  std::sort(fast_order.begin(), fast_order.end(), by_lower_x);
  auto widest = [&](const std::vector<Index>& list) {
    double w = 0.0;
    for (const Index i : list) w = std::max(w, grain[i].hi.x() - grain[i].lo.x());
    return w;
  };
  const double widest_slow = widest(slow), widest_fast = widest(fast_order);
  auto clear_of = [&](Index i, const std::vector<Index>& list, double w) {
    const AABB& g = grain[static_cast<size_t>(i)];
    auto it = std::lower_bound(list.begin(), list.end(), g.lo.x() - w - gap,
                               [&](Index a, double x) { return grain[a].lo.x() < x; });
    for (; it != list.end() && grain[*it].lo.x() <= g.hi.x() + gap; ++it)
      if (*it != i && !g.apart(grain[*it], gap)) return false;
    return true;
  };
  Index carried = 0;
  for (const Index i : fast) {
    const AABB& g = grain[static_cast<size_t>(i)];
    bool isolated = true;
    for (size_t p = 0; p < swept.size() && isolated; ++p)
      if (p != o && topo.objects[p].num_vertices() > 0) isolated = g.apart(swept[p], gap);
    if (!isolated || !clear_of(i, slow, widest_slow) || !clear_of(i, fast_order, widest_fast)) continue;
    const Index v = vb + i;
    const Vec3 step = material_solved_[v] - anchor_[v];
    // A step longer than kLongStepMost r is a blow-up, not a motion: cut there, as a long step is.
    const double f = std::min(1.0, kLongStepMost * r / step.norm());
    anchor_[v] += f * step;
    if (f < 1.0) carry_capped_[v] = 1;
    ++carried;
  }
  return carried;
}

}  // namespace ccfr
