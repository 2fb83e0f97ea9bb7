#include "ccfr/solvers/detecting_solvers.hpp"

#include "ccfr/core/error.hpp"

#include "builtin_solvers.hpp"

#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/distance.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <tuple>

namespace ccfr {

void DetectingSolver::initialize(const Topology& topo, const SimState& state, const SimulationParams& params) {
  detector_ = std::make_unique<CollisionDetector>(
      topo, state.x, params.contact,
      make_broad_phase(params.collision.broad_phase, params.collision.broad_phase_params));
  detector_->set_reuse_skin(params.collision.reuse_skin * params.contact.radius);
  // The response reads the contacts per vertex in the order the region assembly already built.
  detector_->set_record_plane_sources(true);
  regions_.clear(topo.num_vertices());
  num_vertices_ = topo.num_vertices();
  friction_override_.assign(static_cast<size_t>(topo.num_vertices()), -1.0);
  bool any = false;
  for (size_t o = 0; o < topo.objects.size(); ++o) {
    const double mu = params.objects[o].material.friction;
    if (mu < 0.0) continue;
    any = true;
    for (Index v = topo.objects[o].vertex_begin; v < topo.objects[o].vertex_end; ++v) friction_override_[v] = mu;
  }
  if (!any) friction_override_.clear();
}

std::vector<double> DetectingSolver::save_state() const {
  return detector_ ? detector_->reduced_offsets() : std::vector<double>();
}

void DetectingSolver::restore_state(std::span<const double> state) {
  if (!detector_) throw Error("contact solver '" + std::string(name()) + "': restore_state() before initialize()");
  detector_->restore_reduced_offsets(state);
}

DetectResult DetectingSolver::detect(const Positions& anchor, const SimState& state, StepContext& ctx) {
  if (ctx.frame != rebuild_frame_) {
    rebuild_frame_ = ctx.frame;
    detector_->rebuild_broad_phase();
  }
  if (detector_->reuse_skin() > 0.0 && ctx.frame != reuse_frame_) {
    // Frame start: the kept list restarts from what a checkpoint holds (the velocities), so a
    // resumed run lists and reuses exactly where the uninterrupted one did (same stats.csv).
    // The last substep's step dt v, up to one common shift (a scene falling as a whole lists).
    reuse_frame_ = ctx.frame;
    reuse_step_.resize(state.v.size());
    reuse_zero_.assign(state.v.size(), Vec3::Zero());
    for (size_t i = 0; i < state.v.size(); ++i) reuse_step_[i] = ctx.dt * state.v[i];
    detector_->restart_reuse(measure_reuse_motion(ctx.topo, reuse_step_, reuse_zero_).spread);
  }
  DetectionStats ds;
  detector_->detect(anchor, state.inv_mass, regions_, contacts_, ds, ctx.kinematic_step);
  ctx.times.broad += ds.broad_s;
  ctx.times.narrow += ds.narrow_s;
  {
    ScopedTimer t(ctx.times.narrow);  // contact bookkeeping for the response belongs to the narrow phase
    response_.prepare(contacts_, regions_.offsets, detector_->plane_sources(), ctx.params.contact,
                      response_mass(state));
  }
  DetectResult s;
  s.candidates = ds.candidates;
  s.constraints = ds.constraints;
  s.reused = ds.reused;
  for (const auto& c : contacts_) s.min_distance = std::min(s.min_distance, c.distance);
  return s;
}

namespace {
/// Exact distance of a sub-pair's primitives at x (closest points recomputed, not along n).
double pair_distance(const ContactPair& c, const Positions& x) {
  switch (c.kind) {
    case ContactKind::vf:
      return std::sqrt(point_triangle(x[c.v[0]], x[c.v[1]], x[c.v[2]], x[c.v[3]]).distance_sq);
    case ContactKind::ee:
      return std::sqrt(edge_edge(x[c.v[0]], x[c.v[1]], x[c.v[2]], x[c.v[3]]).distance_sq);
    case ContactKind::ve:
      return std::sqrt(point_edge(x[c.v[0]], x[c.v[1]], x[c.v[2]]).distance_sq);
    case ContactKind::vv:
      return std::sqrt(point_point_distance_sq(x[c.v[0]], x[c.v[1]]));
  }
  return 0.0;
}
}  // namespace

std::pair<Index, Index> DetectingSolver::mark_contact_vertices(int frame, std::span<const double> inv_mass) {
  const Index nv = regions_.num_vertices();
  if (frame != contact_marks_frame_ || static_cast<Index>(contact_marks_.size()) != nv) {
    contact_marks_.assign(static_cast<size_t>(nv), 0);
    contact_marks_frame_ = frame;
    contact_marks_count_ = 0;
  }
  // One sequential sweep over the offsets: a few microseconds per 10k vertices, far below detection.
  Index pass = 0;
  for (Index v = 0; v < nv; ++v) {
    if (!(inv_mass[v] > 0.0) || regions_.count(v) == 0) continue;
    ++pass;
    if (!contact_marks_[v]) contact_marks_[v] = 1, ++contact_marks_count_;
  }
  return {pass, contact_marks_count_};
}

Index DetectingSolver::contact_vertex_count(std::span<const double> inv_mass) const {
  std::vector<std::uint8_t> seen(inv_mass.size(), 0);
  Index n = 0;
  for (const auto& c : contacts_)
    for (int k = 0; k < c.size(); ++k)
      if (inv_mass[c.v[k]] > 0.0 && !seen[c.v[k]]) seen[c.v[k]] = 1, ++n;
  return n;
}

std::optional<Index> DetectingSolver::count_outside(const Positions& x, const Positions&, const SimState&,
                                                    StepContext& ctx) const {
  const double keep = 1.0 - ctx.params.debug.audit_tolerance;
  // One rounding scale for every contact's bound: the largest |x|_1 (NaN or infinity if any
  // coordinate is, which makes every bound undecided and sends each pair to the exact distance).
  double scale = 0.0;
  for (const Vec3& p : x) {
    const double s = p.cwiseAbs().sum();
    scale = s > scale || std::isnan(s) ? s : scale;
  }
  std::atomic<Index> close{0};
  std::atomic<Index> first{std::numeric_limits<Index>::max()};
  if (!ctx.violated.empty()) pair_marks_.assign(ctx.violated.size(), 0);
  parallel_for(
      static_cast<Index>(contacts_.size()),
      [&](Index b, Index e) {
        Index local = 0;
        for (Index i = b; i < e; ++i) {
          // Most pairs are settled by the bound along their own normal, four dot products
          // instead of a distance kernel (after a CCFR projection every kept pair is).
          const double need = keep * contacts_[i].offset;
          if (separation_lower_bound(contacts_[i], x, scale) >= need) continue;
          if (!(pair_distance(contacts_[i], x) >= need)) {  // NaN counts
            ++local;
            if (!ctx.violated.empty())
              for (int k = 0; k < contacts_[i].size(); ++k)
                std::atomic_ref<std::uint8_t>(pair_marks_[contacts_[i].v[k]]).store(1, std::memory_order_relaxed);
            Index cur = first.load();
            while (i < cur && !first.compare_exchange_weak(cur, i)) {
            }
          }
        }
        close += local;
      },
      2048);
  if (close.load() > 0 && !ctx.violated.empty()) {
    // The violated pairs' vertices and every vertex they share a contact with: a pair inside its
    // offset needs the room its neighbours give (with them fixed, its region can be empty).
    parallel_for(
        static_cast<Index>(contacts_.size()),
        [&](Index b, Index e) {
          for (Index i = b; i < e; ++i) {
            const ContactPair& c = contacts_[i];
            bool touches = false;
            for (int k = 0; k < c.size(); ++k) touches = touches || pair_marks_[c.v[k]];
            if (touches)
              for (int k = 0; k < c.size(); ++k)
                std::atomic_ref<std::uint8_t>(ctx.violated[c.v[k]]).store(1, std::memory_order_relaxed);
          }
        },
        4096);
  }
  if (close.load() > 0) {
    // The lowest-numbered violation, so the message does not depend on the thread count.
    const ContactPair& c = contacts_[first.load()];
    const auto& topo = ctx.topo;
    auto obj = [&](Index v) { return "'" + topo.object_of_vertex(v).name + "'"; };
    static constexpr const char* kKind[] = {"vertex-face", "edge-edge", "vertex-edge", "vertex-vertex"};
    last_violation_ = std::string(kKind[static_cast<int>(c.kind)]) + " pair between " + obj(c.v[0]) + " (vertex " +
                      std::to_string(c.v[0]) + ") and " + obj(c.v[c.side_a()]) + " (vertex " +
                      std::to_string(c.v[c.side_a()]) + ") at distance " +
                      fmt::format("{:.9g} ({:.6f} of its offset {:.6g})", pair_distance(c, x),
                                  pair_distance(c, x) / c.offset, c.offset);
  }
  return close.load();
}

std::vector<ContactSolver::ClosePair> DetectingSolver::close_pairs(const Positions& x, double keep, size_t max) const {
  std::vector<ClosePair> out;
  for (const ContactPair& c : contacts_) {
    if (out.size() >= max) break;
    const double d = pair_distance(c, x);
    if (d >= keep * c.offset) continue;  // NaN counts, as in count_outside
    ClosePair p;
    p.kind = static_cast<int>(c.kind);
    p.size = c.size();
    p.side_a = c.side_a();
    for (int k = 0; k < c.size(); ++k) p.v[static_cast<size_t>(k)] = c.v[k];
    p.distance = d;
    p.offset = c.offset;
    out.push_back(p);
  }
  return out;
}

std::optional<bool> DetectingSolver::region_empty(Index v, const Positions& anchor) const {
  if (v < 0 || static_cast<size_t>(v) + 1 >= regions_.offsets.size() || regions_.count(v) == 0) return std::nullopt;
  std::vector<HalfSpace> buf;
  const auto planes = regions_.of(v, buf);
  if (!falls_below(anchor[v], anchor[v], planes, 0.0)) return false;  // the anchor is a feasible point
  // The anchor left its own region (a scripted step or a reduced offset moved a plane past it):
  // the exact projection decides, and reports an empty region as infeasible.
  const std::unique_ptr<Projector> exact = make_projector("exact", ProjectorParams{});
  return exact->project(anchor[v], anchor[v], planes).status == ProjectStatus::infeasible;
}

void DetectingSolver::respond(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx) {
  response_.apply(x, state.x_prev, state.inv_mass, ctx.params.contact, ctx.dt, friction_override_);
}

std::span<const double> RegionProjectionSolver::response_mass(const SimState& state) {
  if (rigid_.empty()) return {};
  free_mask_.assign(state.inv_mass.begin(), state.inv_mass.end());
  rigid_.mask_free(free_mask_);
  return free_mask_;
}

void RegionProjectionSolver::respond(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx) {
  if (rigid_.empty()) return DetectingSolver::respond(x, anchor, state, ctx);
  // Unpinned rigid bodies respond in their pose solve (enforce), with their generalized masses:
  // here they count as fixed (a vertex's own mass gave a rigid body a far too weak impulse).
  free_mask_.assign(state.inv_mass.begin(), state.inv_mass.end());
  rigid_.mask_free(free_mask_);
  // A contact between a movable side and an unpinned rigid body: the body's generalized inverse
  // mass at its closest point (frame at the anchor, where the contacts were found) joins the
  // response's, as the pose solve counts the movable side's in its share.
  other_inverse_mass_.assign(contacts_.size(), 0.0);
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
  }
  response_.apply(x, state.x_prev, free_mask_, ctx.params.contact, ctx.dt, friction_override_, other_inverse_mass_);
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
  const BatchStats b = project_all(*projector_, regions_, anchor, x, projected_mass, halted_);
  SolveResult r;
  r.violations_detected = b.violated;
  r.violations_remaining = b.remaining;
  r.halted_vertices = b.halted;
  r.projector_fallbacks = b.fallbacks;
  r.projector_rescues = b.rescued;
  std::tie(r.contact_vertices, r.contact_vertices_distinct) = mark_contact_vertices(ctx.frame, state.inv_mass);
  if (!rigid_.empty()) {
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
      return pc;
    };
    auto plane_repel = [&](Index q) {
      if (sources.size() != regions_.total()) return delta;
      const ContactPair& c = contacts_[static_cast<size_t>(sources[q] / 4)];
      return delta - std::max(0.0, c.distance - c.offset - regions_.plane(q).d);
    };
    RigidContactOptions options;
    options.x_start = &state.x_prev;
    options.repulsion_range = ctx.params.contact.repulsion_range;
    options.repulsion_compliance = 1.0 / (ctx.params.contact.stiffness * ctx.dt * ctx.dt);
    options.plane_contact = plane_contact;
    options.plane_repel = plane_repel;
    const RigidEnforceStats rs =
        rigid_.enforce(x, anchor, regions_, *projector_, ctx.params.contact.radius, ctx.params.time.advance_tolerance,
                       rigid_.predicted_cores(state, ctx.dt, ctx.params.time.gravity), options);
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
  r.halted_vertices_distinct = static_cast<Index>(std::count(halted_.begin(), halted_.end(), std::uint8_t{1}));
  return r;
}

std::optional<Index> RegionProjectionSolver::count_outside(const Positions& x, const Positions& anchor,
                                                           const SimState& state, StepContext& ctx) const {
  // A rigid body is exact to round-off; 1e-9 of its extent is far above that and far below ξ.
  return *DetectingSolver::count_outside(x, anchor, state, ctx) + (rigid_.empty() ? 0 : rigid_.count_deformed(x, 1e-9));
}

void DetectingSolver::vertex_diagnostics(std::vector<std::int32_t>& half_spaces, std::vector<double>& distance,
                                         std::vector<std::uint8_t>&) const {
  const Index n = num_vertices_;
  half_spaces.assign(static_cast<size_t>(n), 0);
  for (Index v = 0; v < std::min(n, regions_.num_vertices()); ++v)
    half_spaces[v] = static_cast<std::int32_t>(regions_.count(v));
  distance.assign(static_cast<size_t>(n), std::numeric_limits<double>::quiet_NaN());
  for (const ContactPair& c : contacts_)
    for (int k = 0; k < c.size(); ++k) {
      double& d = distance[static_cast<size_t>(c.v[k])];
      if (!(d <= c.distance)) d = c.distance;  // NaN (none yet) or farther
    }
}

void RegionProjectionSolver::vertex_diagnostics(std::vector<std::int32_t>& half_spaces, std::vector<double>& distance,
                                                std::vector<std::uint8_t>& halted) const {
  DetectingSolver::vertex_diagnostics(half_spaces, distance, halted);
  halted = halted_;
  halted.resize(half_spaces.size(), 0);
}

SolveResult PostProcessSolver::resolve(Positions& x, const Positions&, const SimState& state, StepContext& ctx) {
  const auto& w = state.inv_mass;
  SolveResult r;
  std::tie(r.contact_vertices, r.contact_vertices_distinct) = mark_contact_vertices(ctx.frame, w);
  r.halted_vertices_distinct = 0;  // nothing here falls back to an anchor
  for (const auto& c : contacts_)
    if (contact_gap(c, x) < 0.0) ++r.violations_detected;
  // Sequential Gauss-Seidel: this is the conventional pass the paper compares against, whose
  // order dependence is part of what the comparison shows.
  for (int sweep = 0; sweep < sweeps_; ++sweep) {
    bool any = false;
    for (const auto& c : contacts_) {
      const double gap = contact_gap(c, x);
      if (gap >= 0.0) continue;
      double wsum = 0.0;
      for (int k = 0; k < c.size(); ++k) wsum += c.w[k] * c.w[k] * w[c.v[k]];
      if (wsum <= 0.0) continue;
      const double dl = -gap / wsum;
      for (int k = 0; k < c.size(); ++k) x[c.v[k]] += w[c.v[k]] * c.w[k] * dl * c.n;
      any = true;
    }
    if (!any) break;
  }
  for (const auto& c : contacts_)
    if (contact_gap(c, x) < -1e-9) ++r.violations_remaining;
  return r;
}

void register_region_projection_solvers(ContactSolverRegistry& registry) {
  // Each exposes its projector's own parameters under contact.<solver>.*.
  auto add = [&](const char* name, const char* projector, const char* description) {
    registry.add({name, description, projectors().at(projector).params,
                  [name = std::string(name), projector = std::string(projector)](const ParamValues& v) {
                    return std::make_unique<RegionProjectionSolver>(name, projector, v);
                  }});
  };
  add("ccfr", "plesnik",
      "per-vertex convex collision-free regions, Plesník projection, the exact projection where it does not "
      "converge, halting fallback (the paper; guarantees separation)");
  add("exact_projection", "exact", "the same regions, the exact Euclidean projection (guarantees separation)");
  add("successive_projection", "successive_projection",
      "the same regions, naive cyclic projection onto one half-space at a time (related work)");
}

void register_post_process_solver(ContactSolverRegistry& registry) {
  registry.add({"post_process",
                "conventional XPBD thickness constraints on the detected pairs inside ξ, Gauss-Seidel, no regions "
                "(the paper's baseline)",
                {ParamSpec::integer("sweeps", PostProcessSolver::kDefaultSweeps,
                                    "Gauss-Seidel sweeps over the thickness constraints per outer iteration", 1)},
                [](const ParamValues& v) {
                  return std::make_unique<PostProcessSolver>(static_cast<int>(v.integer("sweeps")));
                }});
}

}  // namespace ccfr
