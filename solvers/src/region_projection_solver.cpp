// RegionProjectionSolver: a vertex outside its region is projected back onto it by a registered
// projector (paper Alg. 1); `ccfr`, `exact_projection` and `successive_projection` are its
// registrations (contact/*.cpp), differing only in the projector.
#include "ccfr/solvers/region_projection_solver.hpp"

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <mutex>
#include <tuple>

#include "builtin_solvers.hpp"
#include "ccfr/solvers/motion_planes.hpp"

namespace ccfr {
namespace {
/// A set-aside plane's offset: no candidate reaches it.
constexpr double kAside = 1e300;
/// Pose solves a pass may run for its carried vertices before it solves without them.
constexpr int kCarryRounds = 4;
/// How far below the ratio a carried vertex's step asks for a body's bound is cut.
constexpr double kCarryBoundMargin = 1e-3;
}  // namespace

std::span<const double> RegionProjectionSolver::response_mass(const SimState& state) {
  if (rigid_.empty()) return {};
  free_mask_.assign(state.inv_mass.begin(), state.inv_mass.end());
  rigid_.mask_free(free_mask_);
  return free_mask_;
}

void RegionProjectionSolver::respond(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx) {
  // Planes (and their repulsion) turned toward the candidates' closest points where that is sound
  // and lets them slide, before the response and the projection act along them.
  if (ctx.params.contact.sliding)
    turn_by_motion(contacts_, regions_, anchor, x, state.inv_mass, ctx.kinematic_step,
                   ctx.params.contact.repulsion_range);
  if (rigid_.empty()) return DetectingSolver::respond(x, anchor, state, ctx);
  // Unpinned rigid bodies respond in their pose solve (enforce), with their generalized masses:
  // here they count as fixed (a vertex's own mass gave a rigid body a far too weak impulse).
  free_mask_.assign(state.inv_mass.begin(), state.inv_mass.end());
  rigid_.mask_free(free_mask_);
  // A contact between a movable side and an unpinned rigid body: the body's generalized inverse
  // mass at its closest point (frame at the anchor, where the contacts were found) joins the
  // response's, as the pose solve counts the movable side's in its share.
  other_inverse_mass_.assign(contacts_.size(), 0.0);
  answering_body_.assign(contacts_.size(), -1);
  answering_arm_.resize(contacts_.size());
  answering_away_.resize(contacts_.size());
  std::vector<RigidFrame> frames;
  const bool any_movable = std::any_of(free_mask_.begin(), free_mask_.end(), [](double w) { return w > 0.0; });
  for (size_t ci = 0; any_movable && ci < contacts_.size(); ++ci) {
    const ContactPair& c = contacts_[ci];
    const int na = c.side_a();
    bool moves_a = false, moves_b = false;
    for (int k = 0; k < c.size(); ++k) (k < na ? moves_a : moves_b) |= free_mask_[c.v[k]] > 0.0;
    if (moves_a == moves_b) continue;  // both sides movable, or neither
    const int lo = moves_a ? na : 0, hi = moves_a ? c.size() : na;
    const Index body = rigid_.body_of(c.v[lo]);
    if (body < 0) continue;
    if (frames.empty()) frames = rigid_.frames(anchor);
    Vec3 point = Vec3::Zero();
    for (int j = lo; j < hi; ++j) point += std::abs(c.w[j]) * anchor[c.v[j]];
    other_inverse_mass_[ci] = frames[static_cast<size_t>(body)].inverse_mass_at(point, c.n);
    answering_body_[ci] = body;
    answering_arm_[ci] = point - frames[static_cast<size_t>(body)].centre;
    answering_away_[ci] = moves_a ? Vec3(-c.n) : c.n;  // side A gives way along +n, side B along -n
  }
  body_inv_mass_.resize(frames.size());
  body_inv_inertia_.resize(frames.size());
  for (size_t b = 0; b < frames.size(); ++b)
    body_inv_mass_[b] = frames[b].inv_mass, body_inv_inertia_[b] = frames[b].inv_inertia;
  response_.apply(x, state.x_prev, free_mask_, ctx.params.contact, ctx.dt, friction_override_, other_inverse_mass_,
                  ctx.momentum);
  reaction_shift_.assign(static_cast<size_t>(rigid_.size()), Vec3::Zero());
  pair_pressed_.clear();
  pair_answered_.clear();
  if (!ctx.momentum) return;
  AnsweringBodies bodies;
  bodies.body = answering_body_;
  bodies.inverse_mass_at = other_inverse_mass_;
  bodies.arm = answering_arm_;
  bodies.away = answering_away_;
  bodies.inv_mass = body_inv_mass_;
  bodies.inv_inertia = body_inv_inertia_;
  response_.separate(x, anchor, free_mask_, kSeparateSweeps, rest_overlap(ctx), &bodies, ctx.tethers);
  react_bodies(x);
  // Two unpinned bodies in contact push each other, as the response pushes a movable side; not
  // in the paper's path, whose substeps redone with the response above keep their rigid bodies'.
  std::vector<Vec3> shift, turn;
  PairResponse pairs;
  pairs.rest_overlap = rest_overlap(ctx);
  pairs.sweeps = kSeparateSweeps;
  pairs.repulsion_range = ctx.params.contact.repulsion_range;
  pairs.repulsion_compliance = 1.0 / (ctx.params.contact.stiffness * ctx.dt * ctx.dt);
  pairs.inv_mass = state.inv_mass;
  pair_pressed_.clear();
  pair_answered_.clear();
  if (ctx.params.contact.momentum &&
      rigid_.answer_pairs(x, anchor, contacts_, pairs, shift, turn, &pair_pressed_, &pair_answered_) > 0) {
    rigid_.displace(x, shift, turn);
    for (size_t b = 0; b < shift.size(); ++b) reaction_shift_[b] += shift[b];
  }
}

void RegionProjectionSolver::react_bodies(Positions& x) {
  // Each contact's impulse J on the side the body pushed away is, by the third law, an impulse -J
  // on the body along the contact's line at its closest point: separate() summed those of its
  // sweeps (P, L about the centre), and apply()'s repulsion and friction add theirs. The body's
  // centre moves by M⁻¹ P and it turns by I⁻¹ L (the frame at the anchor, where w_o was taken).
  const std::span<const Vec3> push = response_.body_impulse(), twist = response_.body_moment();
  const std::span<const Vec3> repelled = response_.impulse_on_movable();
  const size_t nb = body_inv_mass_.size();
  if (nb == 0 || (push.size() != nb && repelled.size() != contacts_.size())) return;
  std::vector<Vec3> p(nb, Vec3::Zero()), t(nb, Vec3::Zero());
  if (push.size() == nb)
    for (size_t b = 0; b < nb; ++b) p[b] = push[b], t[b] = twist[b];
  if (repelled.size() == contacts_.size())
    for (size_t ci = 0; ci < contacts_.size(); ++ci) {
      const Index b = answering_body_[ci];
      if (b < 0 || repelled[ci] == Vec3::Zero()) continue;
      p[static_cast<size_t>(b)] -= repelled[ci];
      t[static_cast<size_t>(b)] -= answering_arm_[ci].cross(repelled[ci]);
    }
  std::vector<Vec3> turn(nb, Vec3::Zero());
  for (size_t b = 0; b < nb; ++b) {
    reaction_shift_[b] = body_inv_mass_[b] * p[b];
    turn[b] = body_inv_inertia_[b] * t[b];
  }
  rigid_.displace(x, reaction_shift_, turn);
}

RegionProjectionSolver::RegionProjectionSolver(std::string solver_name, std::string projector_name, ParamValues params)
    : name_(std::move(solver_name)), projector_name_(std::move(projector_name)), projector_params_(std::move(params)) {}

void RegionProjectionSolver::initialize(const Topology& topo, const SimState& state, const SimulationParams& params) {
  DetectingSolver::initialize(topo, state, params);
  ProjectorParams pp = apply_projector_params(ProjectorParams{}, projector_params_);
  // ε scales with ξ: an absolute 1e-6 exceeds a vertex's share of a gap at ξ = 0.001, and every
  // projection then snapped back to the anchor (a card stack that could not move).
  pp.epsilon = params.contact.epsilon * params.contact.offset;
  projector_ = make_projector(projector_name_, pp);
  rigid_ = RigidBodies(topo, state, &params);
}

SolveResult RegionProjectionSolver::resolve(Positions& x, const Positions& anchor, const SimState& state,
                                            StepContext& ctx) {
  if (ctx.frame != halted_frame_ || halted_.size() != x.size()) {
    halted_.assign(x.size(), 0);
    halted_frame_ = ctx.frame;
  }
  // Unpinned rigid bodies' vertices are not projected one by one: enforce() resolves their
  // contacts in the body's pose space.
  std::span<const double> projected_mass = state.inv_mass;
  if (!rigid_.empty()) {
    free_mask_.assign(state.inv_mass.begin(), state.inv_mass.end());
    rigid_.mask_free(free_mask_);
    projected_mass = free_mask_;
  }
  // Each pair's plane split by the motion the response left (the dividing plane moves with the pair).
  held_splits_.clear();
  if (ctx.momentum) {
    split_by_motion(regions_, contacts_, anchor, x, state.inv_mass, projected_mass, held_splits_, other_inverse_mass_,
                    pair_answered_);
    if (ctx.push_through) push_through(regions_, contacts_, state.inv_mass, projected_mass, kPushRounds);
  } else if (ctx.free_island.size() == x.size()) {
    // Inside a free island (contact.free_islands) the pairs' planes follow the motion too, without
    // the response: two pieces flying together within reach keep their gap (the paper's fixed
    // split holds the trailing one back at half the gap a pass, and the island's restore then
    // gives the loss to both). Every other contact keeps the paper's split.
    free_split_.resize(x.size());
    for (size_t v = 0; v < x.size(); ++v) free_split_[v] = ctx.free_island[v] ? projected_mass[v] : 0.0;
    split_by_motion(regions_, contacts_, anchor, x, state.inv_mass, free_split_, held_splits_, other_inverse_mass_);
  }
  const BatchStats b = project_all(*projector_, regions_, anchor, x, projected_mass, halted_);
  SolveResult r;
  r.violations_detected = b.violated;
  r.violations_remaining = b.remaining;
  r.halted_vertices = b.halted;
  r.projector_fallbacks = b.fallbacks;
  r.projector_rescues = b.rescued;
  std::tie(r.contact_vertices, r.contact_vertices_distinct) = mark_contact_vertices(ctx.frame, state.inv_mass);
  if (!rigid_.empty()) place_bodies(x, anchor, state, ctx, projected_mass, r);
  r.halted_vertices_distinct = static_cast<Index>(std::count(halted_.begin(), halted_.end(), std::uint8_t{1}));
  // A side held at its old plane while the other moved away: another pass, where the room vacated
  // at these positions is used.
  r.bounded_vertices +=
      held_followers(contacts_, held_splits_, anchor, x, kDeferredRoom * ctx.params.contact.radius, ctx.deferred);
  return r;
}

void RegionProjectionSolver::place_bodies(Positions& x, const Positions& anchor, const SimState& state,
                                          StepContext& ctx, std::span<const double> projected_mass, SolveResult& r) {
  // A halted body is put back at its anchor pose as a whole: its vertices that wanted to move
  // and sit exactly at their anchors afterwards are the halted ones.
  std::vector<std::uint8_t> wanted(x.size(), 0);
  for (const auto& o : ctx.topo.objects)
    if (o.kind == ObjectKind::rigid)
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v) wanted[v] = x[v] != anchor[v];
  // The repulsion of a rigid vertex's plane acts on its pair's gap, which exceeds the plane's
  // value by the other side's share (gap - d), and the pair's other side takes its part of the
  // correction (its inverse masses): against a light cloth a heavy ball then barely moves, as
  // the pair's XPBD repulsion has it, instead of bouncing off a stiff spring.
  const auto sources = detector_->plane_sources();
  const double delta = ctx.params.contact.repulsion_range;
  // An unpinned rigid body on the other side answers with its generalized inverse mass at the
  // closest point (its vertices' own masses would make it a light cloth). Its frame is taken at
  // the anchor, where the regions were built.
  const std::vector<RigidFrame> frames = rigid_.frames(anchor);
  // The candidates as they are before enforce() overwrites the bodies' vertices (concurrently,
  // while other bodies' solves ask for their planes' pairs).
  candidates_.assign(x.begin(), x.end());
  // Asked by the pose solve only for the planes that come within reach of acting (a pass over
  // every plane of a pile's bodies cost a tenth of a landing frame).
  auto plane_contact = [&](Index q) {
    RigidPlaneContact pc;
    pc.repel = delta;
    if (sources.size() != regions_.total()) return pc;
    const ContactPair& c = contacts_[static_cast<size_t>(sources[q] / 4)];
    const int k = static_cast<int>(sources[q] % 4), na = c.side_a();
    const int lo = k < na ? na : 0, hi = k < na ? c.size() : na;
    Vec3 point = Vec3::Zero();
    // The other side's closest point and its motion over the substep (x is every other
    // body's candidate: a cloth's projected, an obstacle's scripted target, a rigid body's
    // predicted position), for the friction on the relative slip.
    for (int j = lo; j < hi; ++j) {
      const Index u = c.v[j];
      pc.other_w += c.w[j] * c.w[j] * state.inv_mass[u];
      pc.other_motion += std::abs(c.w[j]) * (candidates_[u] - state.x_prev[u]);
      point += std::abs(c.w[j]) * anchor[u];
    }
    const HalfSpace h = regions_.plane(q);
    const Vec3 n = h.n;
    pc.other_wt = pc.other_w;
    pc.responds_w = pc.other_w;
    const Index ob = rigid_.body_of(c.v[lo]);
    if (ob >= 0 && frames[static_cast<size_t>(ob)].inv_mass > 0.0) {
      const RigidFrame& f = frames[static_cast<size_t>(ob)];
      pc.responds_w = 0.0;  // answered by its own pose solve
      pc.other_w = f.inverse_mass_at(point, n);
      // Against the tangential correction: the mean over the tangent plane's two axes.
      const Vec3 t1 = n.unitOrthogonal(), t2 = n.cross(t1);
      pc.other_wt = 0.5 * (f.inverse_mass_at(point, t1) + f.inverse_mass_at(point, t2));
    }
    const double gap = c.distance - c.offset;
    pc.repel = delta - std::max(0.0, gap - h.d);
    // Under contact.momentum the response's repulsion of a movable side acts on the body too
    // (react_bodies), with the impulse that side took: the pose solve repels only what does
    // not answer (fixed, scripted, another body).
    if (ctx.momentum && pc.responds_w > 0.0) pc.repel = 0.0;
    // Two unpinned bodies: answer_pairs() repelled the pair as one; its impulse bounds the friction.
    if (paired(sources[q])) pc.repel = 0.0, pc.pressed = paired_press(sources[q]);
    return pc;
  };
  auto plane_repel = [&](Index q) {
    if (sources.size() != regions_.total()) return delta;
    const ContactPair& c = contacts_[static_cast<size_t>(sources[q] / 4)];
    // A pair answer_pairs() pressed stays within reach: its friction acts while it rests within δ.
    if (paired(sources[q])) return paired_press(sources[q]) > 0.0 ? delta : 0.0;
    if (ctx.momentum) {
      const int k = static_cast<int>(sources[q] % 4), na = c.side_a();
      const int lo = k < na ? na : 0, hi = k < na ? c.size() : na;
      bool responds = false;
      for (int j = lo; j < hi; ++j) responds = responds || projected_mass[c.v[j]] > 0.0;
      if (responds) return 0.0;
    }
    return delta - std::max(0.0, c.distance - c.offset - regions_.plane(q).d);
  };
  if (ctx.momentum) {
    // The cloth and solids are placed: the bodies get the room they left (follow_resolved_sides).
    later_.assign(x.size(), 0.0);
    vertex_body_.assign(x.size(), -1);
    for (size_t v = 0; v < x.size(); ++v)
      if (state.inv_mass[v] > 0.0 && !(projected_mass[v] > 0.0))
        later_[v] = 1.0, vertex_body_[v] = rigid_.body_of(static_cast<Index>(v));
    follow_resolved_sides(regions_, contacts_, anchor, x, later_);
  }
  RigidContactOptions options;
  options.x_start = &state.x_prev;
  options.repulsion_range = ctx.params.contact.repulsion_range;
  options.repulsion_compliance = 1.0 / (ctx.params.contact.stiffness * ctx.dt * ctx.dt);
  options.plane_contact = plane_contact;
  options.plane_repel = plane_repel;
  std::vector<Vec3> cores = rigid_.predicted_cores(state, ctx.dt, ctx.params.time.gravity);
  for (size_t b = 0; b < cores.size() && b < reaction_shift_.size(); ++b) cores[b] += reaction_shift_[b];
  const RigidEnforceStats rs = ctx.momentum
                                   ? enforce_carrying(x, anchor, state.inv_mass, ctx, projected_mass, cores, options)
                                   : rigid_.enforce(x, anchor, regions_, ctx.params.contact.radius,
                                                    ctx.params.time.advance_tolerance, cores, options);
  r.violations_detected += rs.vertices_violated;
  r.halted_vertices += rs.vertices_halted;
  r.bounded_vertices += rs.bodies_bounded;
  if (rs.bodies_halted > 0)
    for (const auto& o : ctx.topo.objects) {
      if (o.kind != ObjectKind::rigid) continue;
      bool at_anchor = true, moved = false;
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v) {
        at_anchor = at_anchor && x[v] == anchor[v];
        moved = moved || wanted[v];
      }
      if (at_anchor && moved)
        for (Index v = o.vertex_begin; v < o.vertex_end; ++v) halted_[v] = 1;
    }
}

bool RegionProjectionSolver::paired(size_t source) const {
  const size_t ci = source / 4;
  return ci < pair_answered_.size() && pair_answered_[ci] == 1;
}

double RegionProjectionSolver::paired_press(size_t source) const {
  // Shared over the side's vertices by their weights, as the pose solve's own was over their planes.
  const size_t ci = source / 4;
  return ci < pair_pressed_.size() ? std::abs(contacts_[ci].w[source % 4]) * pair_pressed_[ci] : 0.0;
}

bool RegionProjectionSolver::carried_plane_holds(std::uint32_t ref, const Positions& anchor, std::span<const Vec3> ends,
                                                 std::span<const double> inv_mass, const Vec3& from, const Vec3& to,
                                                 double shrink) const {
  const size_t ci = ref >> 1;
  const ContactPair& c = contacts_[ci];
  const RegionRecord& rec = regions_.records[ci];
  // One rigid motion keeps the pair's distance at the end; on the way the vertices follow one
  // affine map, which shortens it by at most cos(θ/2): the gap at the anchor must cover that.
  if (moves_with_one_body(c, vertex_body_, carrier_)) return c.distance - c.offset >= shrink * c.offset;
  // The room the other side leaves where all its vertices end, a_O their largest approach along
  // n: G - a_O. Then a_S + a_O <= G for the sides' largest approaches (the vertex that is not
  // carried ends where its region or the body's follow room put it), and on the straight paths
  // each is convex in time and zero at the anchor, so the sum stays below G throughout. A fixed
  // or scripted vertex gives no room by moving away: a record with such a side may already have
  // counted its retreat (mixed_pair_record measures from where it ends).
  const int side = static_cast<int>(ref & 1), na = c.side_a();
  double approach = -std::numeric_limits<double>::infinity();
  for (int k = side == 0 ? na : 0; k < (side == 0 ? c.size() : na); ++k) {
    const Index u = c.v[k];
    const double along = rec.n.dot(ends[static_cast<size_t>(u)] - anchor[u]);
    const double toward = side == 0 ? along : -along;
    approach = std::max(approach, inv_mass[u] != 0.0 ? toward : std::max(toward, 0.0));
  }
  const double d = rec.d[0] + rec.d[1] - approach;
  const Vec3 n = side == 0 ? rec.n : Vec3(-rec.n);
  return (to - from).dot(n) + d >= 0.0;
}

bool RegionProjectionSolver::carry_along(std::uint32_t ref, Index body, std::span<const double> projected_mass,
                                         const Positions& x, std::vector<Index>& carried,
                                         std::vector<Vec3>& projected) {
  const ContactPair& c = contacts_[ref >> 1];
  for (int k = 0; k < c.size(); ++k) {
    const Index u = c.v[k];
    if (vertex_body_[u] != body && (vertex_body_[u] >= 0 || rigid_.body_of(u) >= 0 || !(projected_mass[u] > 0.0) ||
                                    (carrier_[u] >= 0 && carrier_[u] != body)))
      return false;
  }
  bool added = false;
  for (int k = 0; k < c.size(); ++k) {
    const Index u = c.v[k];
    if (carrier_[u] >= 0 || vertex_body_[u] >= 0) continue;
    carrier_[u] = body;
    added = true;
    // One let go in an earlier round is listed already (its x is its projection again).
    if (std::find(carried.begin(), carried.end(), u) != carried.end()) continue;
    carried.push_back(u);
    projected.push_back(x[u]);
  }
  return added;
}

std::vector<double> RegionProjectionSolver::place_ends(const Positions& x, const Positions& anchor,
                                                       std::span<const double> inv_mass, const StepContext& ctx,
                                                       std::span<const RigidMotion> motion) {
  // A carried vertex ends where its body's motion takes it, any other where the step bound
  // applied after the pass leaves it (apply_step_bound's rule).
  const double r = ctx.params.contact.radius;
  ends_.resize(x.size());
  parallel_for(
      static_cast<Index>(x.size()),
      [&](Index b, Index e) {
        for (Index u = b; u < e; ++u) {
          if (carrier_[u] >= 0) {
            ends_[u] = motion[static_cast<size_t>(carrier_[u])](anchor[u]);
            continue;
          }
          const Vec3 d = x[u] - anchor[u];
          const double len = d.norm(), reach = ctx.vertex_reach.empty() ? r : ctx.vertex_reach[u];
          ends_[u] = inv_mass[u] != 0.0 && len > reach ? Vec3(anchor[u] + (reach / len) * d) : x[u];
        }
      },
      4096);
  std::vector<double> longest(static_cast<size_t>(rigid_.size()), 0.0);
  for (size_t v = 0; v < x.size(); ++v)
    if (vertex_body_[v] >= 0) {
      double& l = longest[static_cast<size_t>(vertex_body_[v])];
      l = std::max(l, (x[v] - anchor[v]).norm());
    }
  return longest;
}

RigidEnforceStats RegionProjectionSolver::enforce_carrying(Positions& x, const Positions& anchor,
                                                           std::span<const double> inv_mass, const StepContext& ctx,
                                                           std::span<const double> projected_mass,
                                                           std::span<const Vec3> cores,
                                                           const RigidContactOptions& options) {
  auto enforce = [&] {
    return rigid_.enforce(x, anchor, regions_, ctx.params.contact.radius, ctx.params.time.advance_tolerance, cores,
                          options);
  };
  if (mark_carried(contacts_, regions_, anchor, x, vertex_body_, projected_mass, carrier_) == 0) return enforce();
  std::vector<Index> carried;
  for (size_t v = 0; v < carrier_.size(); ++v)
    if (carrier_[v] >= 0) {
      // A pinned body's free vertices follow their pins (RigidBodies::enforce), not another body.
      if (rigid_.body_of(static_cast<Index>(v)) >= 0)
        carrier_[v] = -1;
      else
        carried.push_back(static_cast<Index>(v));
    }
  if (carried.empty()) return enforce();
  std::vector<Vec3> projected(carried.size());
  for (size_t i = 0; i < carried.size(); ++i) projected[i] = x[carried[i]];
  struct Aside {
    size_t contact;
    double d[2];
  };
  std::vector<Aside> aside;
  std::mutex gather;
  // A body whose motion takes a carried vertex past its step bound moves less: its own bound is
  // cut by the ratio (the vertex's step is about proportional to the body's).
  const double r = ctx.params.contact.radius;
  std::vector<double> bound(static_cast<size_t>(rigid_.size()), r);
  RigidContactOptions bounded = options;
  bounded.body_step_bound = bound;
  for (int round = 0;; ++round) {
    // A pair one motion moves whole keeps its distance: its planes leave the pose solve.
    aside.clear();
    parallel_for(
        static_cast<Index>(contacts_.size()),
        [&](Index b, Index e) {
          std::vector<Aside> local;
          for (Index ci = b; ci < e; ++ci) {
            if (!moves_with_one_body(contacts_[ci], vertex_body_, carrier_)) continue;
            RegionRecord& rec = regions_.records[static_cast<size_t>(ci)];
            local.push_back({static_cast<size_t>(ci), {rec.d[0], rec.d[1]}});
            rec.d[0] = rec.d[1] = kAside;
          }
          if (local.empty()) return;
          const std::lock_guard<std::mutex> lock(gather);
          aside.insert(aside.end(), local.begin(), local.end());
        },
        4096);
    RigidEnforceStats rs;
    {
      // The set-aside offsets come back however the pose solves end.
      struct Restore {
        std::vector<Aside>& aside;
        RegionSet& regions;
        ~Restore() {
          for (const Aside& a : aside) std::copy(a.d, a.d + 2, regions.records[a.contact].d);
        }
      } restore{aside, regions_};
      rs = rigid_.enforce(x, anchor, regions_, r, ctx.params.time.advance_tolerance, cores, bounded);
    }
    // Each carried vertex goes where its body's motion takes its anchor, if its other planes
    // (those of pairs the motion does not move whole) hold there.
    const std::vector<RigidMotion> motion = rigid_.motions(anchor, x);
    const std::vector<double> longest = place_ends(x, anchor, inv_mass, ctx, motion);
    Index failed = 0;
    std::vector<double> cut = bound;
    for (size_t i = 0; i < carried.size(); ++i) {
      const Index v = carried[i];
      if (carrier_[v] < 0) continue;
      const size_t body = static_cast<size_t>(carrier_[v]);
      const RigidMotion& m = motion[body];
      const Vec3 p = m(anchor[v]);
      // A turn of less than 120° (the affine map's shrink below 2), its other planes holding,
      // and within the vertex's step bound (applied after the pass: a cut would leave it behind
      // its body). Past that bound alone, the body's own bound is cut by the ratio; at a plane,
      // the pair's other movable vertices come along where they can; otherwise it is let go.
      const double reach = ctx.vertex_reach.empty() ? r : ctx.vertex_reach[v];
      const double cos_half = std::cos(0.5 * Eigen::AngleAxisd(m.turn).angle());
      bool holds = cos_half > 0.5;
      const double shrink = holds ? 1.0 / cos_half - 1.0 : 0.0;
      std::uint32_t failing = 0;
      for (Index q = regions_.row_start[v]; q < regions_.row_start[v + 1] && holds; ++q) {
        failing = regions_.refs[static_cast<size_t>(q)];
        holds = carried_plane_holds(failing, anchor, ends_, inv_mass, anchor[v], p, shrink);
      }
      const double step = (p - anchor[v]).norm();
      if (!holds) {
        if (!(cos_half > 0.5 && carry_along(failing, carrier_[v], projected_mass, x, carried, projected)))
          carrier_[v] = -1;
        ++failed;
      } else if (step > reach) {
        cut[body] = std::min(cut[body], longest[body] * (reach / step) * (1.0 - kCarryBoundMargin));
        ++failed;
      } else {
        x[v] = p;
      }
    }
    if (failed == 0) return rs;
    // Another solve: the bodies from their candidates, the vertices from their projections, the
    // vertices that could not come along now planes of the bodies (after kCarryRounds, all).
    for (size_t i = 0; i < carried.size(); ++i) {
      x[carried[i]] = projected[i];
      if (round + 1 >= kCarryRounds) carrier_[carried[i]] = -1;
    }
    for (size_t v = 0; v < x.size(); ++v)
      if (vertex_body_[v] >= 0) x[v] = candidates_[v];
    if (round + 1 >= kCarryRounds) return enforce();
    std::copy(cut.begin(), cut.end(), bound.begin());
  }
}

std::optional<Index> RegionProjectionSolver::count_outside(const Positions& x, const Positions& anchor,
                                                           const SimState& state, StepContext& ctx) const {
  // A rigid body is exact to round-off; 1e-9 of its extent is far above that and far below ξ.
  return *DetectingSolver::count_outside(x, anchor, state, ctx) + (rigid_.empty() ? 0 : rigid_.count_deformed(x, 1e-9));
}

void RegionProjectionSolver::vertex_diagnostics(std::vector<std::int32_t>& half_spaces, std::vector<double>& distance,
                                                std::vector<std::uint8_t>& halted) const {
  DetectingSolver::vertex_diagnostics(half_spaces, distance, halted);
  halted = halted_;
  halted.resize(half_spaces.size(), 0);
}

ContactSolverRegistry::Entry region_projection_entry(const char* name, const char* projector, const char* description) {
  // Each exposes its projector's own parameters under contact.<solver>.*.
  return {name, description, projectors().at(projector).params,
          [name = std::string(name), projector = std::string(projector)](const ParamValues& v) {
            return std::make_unique<RegionProjectionSolver>(name, projector, v);
          }};
}

}  // namespace ccfr
