#include "ccfr/solvers/simulation.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "ccfr/core/bounds.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/solvers/obstacles.hpp"
#include "ccfr/solvers/step_bound.hpp"
#include "inverse_mass_mask.hpp"

namespace ccfr {

Simulation::Simulation(Scene scene) : scene_(std::move(scene)) {
  const auto& topo = scene_.topo;
  auto& st = scene_.state;
  const auto& params = scene_.params;
  contact_ = make_contact_solver(params.contact.solver, params.contact.solver_params);

  // Material constraints of every object kind (docs/materials.md); coloured with the final pins.
  materials_ = MaterialSystem(topo, st, params);
  tethers_ = Tethers(topo, st, params);  // none unless contact.momentum and contact.tethers

  // Kinematic vertices: obstacles follow their object's motion, pins their group's motion.
  std::vector<const Motion*> motion_of(static_cast<size_t>(topo.num_vertices()), nullptr);
  std::vector<bool> is_kin(static_cast<size_t>(topo.num_vertices()), false);
  for (size_t oi = 0; oi < topo.objects.size(); ++oi) {
    const auto& o = topo.objects[oi];
    const auto& op = params.objects[oi];
    if (o.kinematic())
      for (Index v = o.vertex_begin; v < o.vertex_end; ++v) is_kin[v] = true, motion_of[v] = &op.motion;
    for (const auto& pin : op.pins)
      for (Index lv : pin.vertices) is_kin[o.vertex_begin + lv] = true, motion_of[o.vertex_begin + lv] = &pin.motion;
    // Distance functions act only for obstacles (they follow the obstacle's script) and only under
    // contact.analytic_obstacles.
    if (params.contact.analytic_obstacles && o.kinematic() && op.shape.type != AnalyticShape::Type::none)
      analytic_obstacles_.push_back(static_cast<Index>(oi));
  }
  kin_slot_.assign(static_cast<size_t>(topo.num_vertices()), -1);
  for (Index v = 0; v < topo.num_vertices(); ++v)
    if (is_kin[v]) {
      kin_slot_[v] = static_cast<Index>(kinematic_.size());
      kinematic_.push_back(v);
      kin_motion_.push_back(motion_of[v] && motion_of[v]->moves() ? motion_of[v] : nullptr);
    }
  contact_->initialize(topo, st, params);
  init_adaptive_reach();
  check_finite(st.x, "initial state");
  const auto mc = materials_.counts();
  std::string constraints;  // every material constraint's batch, by registered name
  for (const auto& [name, n] : mc.by_name) constraints += std::to_string(n) + " " + name + ", ";
  log::info(
      "scene '{}': {} objects, {} vertices, {} faces, {} edges, {} tets; constraints: {}{} rigid bodies ({} colours); "
      "{} kinematic vertices; contact solver '{}'",
      params.scene_name, topo.objects.size(), topo.num_vertices(), topo.num_faces(), topo.num_edges(), topo.tets.size(),
      constraints, mc.rigid_bodies, mc.colours, kinematic_.size(), contact_->name());
}

Simulation::~Simulation() = default;

SimulationCheckpoint Simulation::checkpoint() const {
  const auto& st = scene_.state;
  SimulationCheckpoint c;
  c.frame = frame_;
  c.time = st.time;
  c.x = st.x;
  c.v = st.v;
  c.x_prev = st.x_prev;
  c.solver_state = contact_->save_state();
  c.warned_violation = warned_violation_;
  c.warned_capped.assign(warned_capped_.begin(), warned_capped_.end());
  return c;
}

void Simulation::restore(const SimulationCheckpoint& c) {
  auto& st = scene_.state;
  const size_t nv = st.x.size();
  if (c.x.size() != nv || c.v.size() != nv || c.x_prev.size() != nv)
    throw Error("checkpoint holds " + std::to_string(c.x.size()) + " positions and " + std::to_string(c.v.size()) +
                " velocities, the scene has " + std::to_string(nv) + " vertices");
  if (!c.warned_capped.empty() && c.warned_capped.size() != scene_.topo.objects.size())
    throw Error("checkpoint has " + std::to_string(c.warned_capped.size()) + " objects, the scene has " +
                std::to_string(scene_.topo.objects.size()));
  if (c.frame < 0 || !std::isfinite(c.time) || c.time < 0.0)
    throw Error("checkpoint frame " + std::to_string(c.frame) + " at time " + std::to_string(c.time) + " is invalid");
  for (const Positions* p : {&c.x, &c.v, &c.x_prev})
    for (size_t i = 0; i < nv; ++i)
      if (!(*p)[i].allFinite()) throw Error("checkpoint has a non-finite value at vertex " + std::to_string(i));
  contact_->restore_state(c.solver_state);
  st.x = c.x;
  st.v = c.v;
  st.x_prev = c.x_prev;
  st.time = c.time;
  frame_ = c.frame;
  warned_violation_ = c.warned_violation;
  warned_capped_.assign(c.warned_capped.begin(), c.warned_capped.end());
}

double Simulation::kinematic_targets(double t, Positions& target) {
  const auto& st = scene_.state;
  kinematic_step_.assign(st.x.size(), Vec3::Zero());
  double largest = 0.0;
  // Driven vertices: the fraction of the frame done at t (1 within rounding of the frame's end,
  // so that the target is reached exactly).
  const double span = drive_t1_ - drive_t0_;
  const double s = span <= 0.0 || t >= drive_t1_ - 1e-9 * span ? 1.0 : std::clamp((t - drive_t0_) / span, 0.0, 1.0);
  for (size_t k = 0; k < kinematic_.size(); ++k) {
    const Index v = kinematic_[k];
    if (!driven_.empty() && driven_[k]) {
      target[v] = s == 1.0 ? driven_to_[k] : Vec3(driven_from_[k] + s * (driven_to_[k] - driven_from_[k]));
    } else {
      if (!kin_motion_[k]) continue;
      const Motion& m = *kin_motion_[k];
      target[v] =
          m.animation ? m.animation->at(v - scene_.topo.object_of_vertex(v).vertex_begin, t) : m.apply(st.rest[v], t);
    }
    kinematic_step_[v] = target[v] - st.x[v];
    largest = std::max(largest, kinematic_step_[v].norm());
  }
  return largest;
}

void Simulation::check_finite(const Positions& x, const char* stage) const {
  std::atomic<Index> first{std::numeric_limits<Index>::max()};
  parallel_for(
      static_cast<Index>(x.size()),
      [&](Index b, Index e) {
        for (Index i = b; i < e; ++i)
          // Beyond the bound is refused like non-finite: frames must stay readable by render,
          // export and the audit, which refuse such coordinates.
          if (!(x[i].cwiseAbs().maxCoeff() <= kMaxCoordinate)) {
            Index cur = first.load();
            while (i < cur && !first.compare_exchange_weak(cur, i)) {
            }
            return;
          }
      },
      4096);
  const Index v = first.load();
  if (v == std::numeric_limits<Index>::max()) return;
  // The last line of defence: the stage, the object and the vertex, global and within its object.
  const auto& o = scene_.topo.object_of_vertex(v);
  if (x[v].allFinite())
    throw Error("position beyond +-1e6 (ccfr's bound on coordinates) at frame " + std::to_string(frame_ + 1) +
                ", vertex " + std::to_string(v) + " (object '" + o.name + "', vertex " +
                std::to_string(v - o.vertex_begin) + " of the object), after stage '" + stage + "'");
  throw NumericalError(frame_ + 1, v, stage, o.name, v - o.vertex_begin);
}

void Simulation::collide_analytic(Positions& x, double t) const {
  if (analytic_obstacles_.empty()) return;
  const auto& st = scene_.state;
  const double offset = scene_.params.contact.offset;
  parallel_for(
      static_cast<Index>(x.size()),
      [&](Index b, Index e) {
        for (Index i = b; i < e; ++i) {
          if (st.inv_mass[i] == 0.0) continue;
          for (Index oi : analytic_obstacles_) {
            const auto& op = scene_.params.objects[oi];
            Vec3 n;
            const double d = analytic_sdf(op.shape, op.motion, t, x[i], n);
            if (d < offset) x[i] += (offset - d) * n;
          }
        }
      },
      1024);
}

std::string Simulation::kinematic_overrun(double kin_step) {
  const double r = scene_.params.contact.radius;
  // Where the script wanted its vertices at the start of this piece, against where they are: a
  // solver that moves scripted vertices with the rest (toi_clamp interpolates the whole system)
  // leaves them behind, and the lag, not the substep, makes the next step too long.
  Positions scripted = scene_.state.x;
  kinematic_targets(scene_.state.time, scripted);
  double lag = 0.0;
  Index worst = -1;
  for (Index v : kinematic_)
    if (const double d = (scripted[v] - scene_.state.x[v]).norm(); d > lag) lag = d, worst = v;
  if (lag > 0.1 * r)
    return ccfr::format(
        "scripted vertices of object '{}' lag their script by {:.4g} (contact solver '{}' held them back with the "
        "rest of the scene), so their next substep piece is {:.4g}, more than r = {:.4g}: this solver cannot follow "
        "the scene's scripted motion; use a solver that leaves scripted vertices on their path (ccfr, ogc, dat, ...)",
        scene_.topo.object_of_vertex(worst).name, lag, contact_->name(), kin_step, r);
  return ccfr::format(
      "scripted vertices move {:.4g} in one substep piece, more than r = {:.4g}, after subdivision; "
      "raise time.substeps",
      kin_step, r);
}

int Simulation::subdivision(double dt) {
  const auto& st = scene_.state;
  const auto& tp = scene_.params.time;
  const double r = scene_.params.contact.radius;
  if (!contact_->clamps_to_radius()) return 1;
  // Scripted vertices: their step must stay within r per piece (the regions leave room for a known
  // step only within the search range). 0.9 leaves room for curved paths between the pieces.
  predicted_.resize(st.x.size());
  const double kin = kinematic_targets(st.time + dt, predicted_);
  int pieces = 1;
  Index worst_kin = -1;
  // Piece counts are capped in double before they become an int (a step of 1e296 m is finite).
  const double cap = static_cast<double>(tp.max_subdivision) + 1.0;
  auto count = [cap](double pieces_needed) { return static_cast<int>(std::min(std::ceil(pieces_needed), cap)); };
  if (kin > 0.0) {
    pieces = std::max(pieces, count(kin / (0.9 * r)));
    double best = 0.0;
    for (Index v : kinematic_)
      if (kinematic_step_[v].norm() > best) best = kinematic_step_[v].norm(), worst_kin = v;
  }
  // Dynamic vertices: the free-flight advance dt v + dt^2 g must fit in the outer iterations'
  // step bounds (one iteration is kept for the corrections of constraints and contact). Below
  // that, extra outer iterations (up to time.max_iterations) cover it more cheaply than pieces.
  const Vec3 g_dt2 = tp.gravity * dt * dt;
  const Index nv = st.size();
  std::vector<double> chunk_max(static_cast<size_t>(default_chunk_count(nv)), 0.0);
  parallel_chunks(nv, static_cast<Index>(chunk_max.size()), [&](Index c, Index b, Index e) {
    double m = 0.0;
    for (Index i = b; i < e; ++i)
      if (st.inv_mass[i] > 0.0) m = std::max(m, (dt * st.v[i] + g_dt2).norm());
    chunk_max[c] = m;
  });
  const double advance = *std::max_element(chunk_max.begin(), chunk_max.end());
  const double per_substep = 0.9 * std::max(1, tp.iteration_bound() - 1) * r;
  if (std::isfinite(advance)) pieces = std::max(pieces, count(advance / per_substep));
  if (pieces > tp.max_subdivision) {
    if (worst_kin >= 0 && kin / tp.max_subdivision > r) {
      const auto& o = scene_.topo.object_of_vertex(worst_kin);
      const double needed = std::ceil(tp.substeps * kin / (0.9 * r));
      throw GuaranteeError(frame_ + 1,
                           "scripted vertices of object '" + o.name + "' move " + ccfr::format("{:.4g}", kin) +
                               " per substep, more than time.max_subdivision = " + std::to_string(tp.max_subdivision) +
                               " pieces of r = " + ccfr::format("{:.4g}", r) +
                               " can absorb; set time.substeps to at least " + ccfr::format("{:.0f}", needed) +
                               " or raise time.max_subdivision");
    }
    pieces = tp.max_subdivision;  // dynamic speed beyond the cap: report_capped_speed names it
  }
  return pieces;
}

void Simulation::report_capped_speed(Index vertex, double advance, double dt) {
  const Index oi = scene_.topo.vertex_object[vertex];
  if (warned_capped_.empty()) warned_capped_.assign(scene_.topo.objects.size(), false);
  if (warned_capped_[oi]) return;
  warned_capped_[oi] = true;
  const auto& p = scene_.params;
  const int n = p.time.iteration_bound();
  log::warn(
      "frame {}: object '{}' wants to move {:.4g} m in a substep piece ({:.3g} m/s) but the step bound allows "
      "{} iterations x r = {:.4g} m: it is slowed to {:.3g} m/s (counted in clamped_vertices). Raise "
      "time.max_iterations, time.substeps or time.max_subdivision, or contact.radius",
      frame_ + 1, scene_.topo.objects[oi].name, advance, advance / dt, n, n * p.contact.radius,
      n * p.contact.radius / dt);
}

Simulation::OuterIterationEnd Simulation::end_outer_iteration(const SolveResult& res, double t1, StepContext& ctx,
                                                              std::span<std::uint8_t> held) {
  const auto& st = scene_.state;
  const auto& tp = scene_.params.time;
  OuterIterationEnd end;
  end.remaining = res.violations_remaining;
  end.held_back = res.bounded_vertices;
  // Analytic obstacles (planes, spheres) push vertices out; their motion is known at t1.
  collide_analytic(solve_, t1);
  check_finite(solve_, "contact resolution");
  // Step bound: no vertex moves farther than r from its anchor in one outer iteration, so
  // primitives not seen by this iteration's detection cannot be reached (paper Alg. line 16).
  if (contact_->clamps_to_radius()) {
    // Under an adaptive reach each vertex is bound by its own ρ, and those it holds back get r next pass.
    if (reach_pass_ && held.empty()) held = reach_held_;
    const StepBoundResult sb =
        apply_step_bound(solve_, anchor_, st.inv_mass, scene_.params.contact.radius, tp.advance_tolerance, solve_, held,
                         reach_pass_ ? std::span<const double>(vertex_reach_) : std::span<const double>());
    end.held_back += sb.held_back;
    end.worst = sb.worst;
    end.worst_length = sb.worst_length;
    end.short_enough =
        tp.advance_shortfall > 0.0 && res.bounded_vertices == 0 && sb.cut <= tp.advance_shortfall * sb.intended;
  }
  // What the iteration really ends with, after the push and the bound moved vertices again.
  if (const auto recount = contact_->count_outside(solve_, anchor_, st, ctx)) end.remaining = *recount;
  return end;
}

namespace {
/// Adds one pass's detection counts to the frame's.
void add_detection(FrameStats& fs, const DetectResult& det) {
  fs.candidates = std::max(fs.candidates, det.candidates);
  fs.candidates_total += det.candidates;
  fs.detections_reused += det.reused;
  fs.constraints = std::max(fs.constraints, det.constraints);
  fs.min_distance = std::min(fs.min_distance, det.min_distance);
}

/// Adds one pass's resolution counts to the frame's; distinct counts are running, the largest is the frame's.
void add_resolution(FrameStats& fs, const SolveResult& res) {
  fs.violations_detected += res.violations_detected;
  fs.halted_vertices += res.halted_vertices;
  fs.contact_vertices += res.contact_vertices;
  fs.projector_fallbacks += res.projector_fallbacks;
  fs.projector_rescues += res.projector_rescues;
  fs.halted_vertices_distinct = std::max(fs.halted_vertices_distinct, res.halted_vertices_distinct);
  fs.contact_vertices_distinct = std::max(fs.contact_vertices_distinct, res.contact_vertices_distinct);
  ++fs.outer_iterations;
}
}  // namespace

bool Simulation::reset_continuation_marks() {
  // time.continuation: held_back. A pass after the first moves only the vertices of the pass
  // before that the step bound held back or whose pairs its recount found closer than their
  // offset; every other vertex runs it with an inverse mass of 0, so detection, response and
  // projection treat it as fixed where that pass left it and skip its pairs with other fixed
  // vertices. Those pairs were recounted clean by an earlier pass and did not move, so the recount
  // of the moving vertices' pairs is the whole scene's. A rigid body moves as a whole, so a scene
  // with one runs full passes, and so does a pass after a recount that could not name its pairs.
  const bool local = scene_.params.time.continuation == TimeParams::Continuation::held_back &&
                     contact_->clamps_to_radius() &&
                     std::none_of(scene_.topo.objects.begin(), scene_.topo.objects.end(),
                                  [](const auto& o) { return o.kind == ObjectKind::rigid; });
  const size_t n = local ? static_cast<size_t>(scene_.state.size()) : 0;
  held_marks_.assign(n, 0);
  violated_marks_.assign(n, 0);
  deferred_marks_.assign(n, 0);
  return local;
}

void Simulation::solve_materials(FrameStats& fs, int substep_index, const StepContext& ctx) {
  // Solve from the prediction (design clarification 6) with fresh multipliers: paper Alg.
  // "Our simulation loop" lines 5-9. Their result depends only on the prediction, dt and the
  // masses, all fixed within the substep, so the sweeps run in the first outer iteration and
  // later iterations start from their result (bit-identical; a third of the twisting cloth's
  // XPBD stage, whose rope frames run up to 5 outer iterations per substep).
  ScopedTimer t(fs.times.xpbd, fs.times.xpbd_serial);
  material_solved_ = predicted_;
  materials_.reset_multipliers();
  for (int s = 0; s < scene_.params.time.xpbd_sweeps; ++s) {
    if (s > 0 && s % 64 == 0) check_cancel(substep_index);
    materials_.solve(material_solved_, scene_.state.inv_mass, ctx.dt);
    tethers_.enforce(material_solved_, scene_.state.inv_mass);
  }
  check_finite(material_solved_, "xpbd");
}

Index Simulation::carry_before_detection(FrameStats& fs) {
  // A body touching nothing is carried by its rigid motion before the regions are built: its
  // own pairs would otherwise hold back some vertices while the others fly on (a soft knot at
  // 3 m/s tore by 15 mm in a frame and intersected itself).
  if (!contact_->clamps_to_radius()) return 0;
  ScopedTimer t(fs.times.check, fs.times.check_serial);
  if (carry_isolated_objects() == 0) return 0;
  return static_cast<Index>(std::count(carry_capped_.begin(), carry_capped_.end(), std::uint8_t{1}));
}

void Simulation::start_from_materials(FrameStats& fs, bool masked, Index capped, StepContext& ctx) {
  const auto& st = scene_.state;
  ScopedTimer t(fs.times.xpbd, fs.times.xpbd_serial);
  solve_ = material_solved_;
  // Vertices fixed for this pass (or carried only part of their way) start and stay where they are.
  if (masked || capped > 0)
    parallel_for(
        st.size(),
        [&](Index b, Index e) {
          for (Index i = b; i < e; ++i)
            if (!(st.inv_mass[i] > 0.0) || (capped > 0 && carry_capped_[i])) solve_[i] = anchor_[i];
        },
        4096);
  contact_->respond(solve_, anchor_, st, ctx);
  check_finite(solve_, "contact response");
}

bool Simulation::finish_pass(const SolveResult& res, double t1, bool local, bool masked, Index capped, StepContext& ctx,
                             OuterIterationEnd& end) {
  if (local) std::fill(violated_marks_.begin(), violated_marks_.end(), std::uint8_t{0});
  ctx.violated = violated_marks_;
  end = end_outer_iteration(res, t1, ctx, held_marks_);
  ctx.violated = {};
  if (capped > 0) {
    // A body carried only part of its way has not reached its intended advance: held back.
    end.held_back += capped;
    // Its farthest vertex names it in the warning of a capped speed, as for held-back ones.
    if (!end.worst)
      for (Index i = 0; i < scene_.state.size(); ++i)
        if (carry_capped_[i]) {
          const double len = (material_solved_[i] - anchor_[i]).norm();
          if (!end.worst || len > end.worst_length) end.worst = i, end.worst_length = len;
        }
    if (local)
      for (size_t i = 0; i < held_marks_.size(); ++i) held_marks_[i] |= carry_capped_[i];
  }
  if (!local) return false;
  // The next pass frees the held back and the vertices around violated pairs. A full pass
  // follows a recount that found violations but named no vertex, and a moving few that
  // could not clear theirs.
  bool named = false;
  for (size_t i = 0; i < held_marks_.size(); ++i) {
    named = named || violated_marks_[i];
    held_marks_[i] |= violated_marks_[i] | deferred_marks_[i];
  }
  return end.remaining == 0 || (named && !masked);
}

Simulation::PassesEnd Simulation::run_passes(FrameStats& fs, int substep_index, double t1, bool kin_moves,
                                             StepContext& ctx) {
  auto& st = scene_.state;
  const auto& tp = scene_.params.time;
  contact_->rewind_substep();  // each solve of a substep starts from the contact state at its start
  anchor_ = st.x;
  start_islands();
  const bool local = reset_continuation_marks();
  bool next_local = false, uniform_next = false;
  const bool guarantees = contact_->guarantees_separation();
  PassesEnd end;
  // Until no vertex is held back by r (often after one pass, so fewer than time.iterations may
  // run), at most iteration_bound() passes.
  const int bound = tp.iteration_bound();
  for (int it = 0; it < bound; ++it) {
    if (it > 0) check_cancel(substep_index);
    ctx.iteration = it;
    end.iterations = it + 1;
    const InverseMassMask mask(
        st.inv_mass, inv_mass_saved_,
        next_local ? std::span<const std::uint8_t>(held_marks_) : std::span<const std::uint8_t>());
    ctx.kinematic_step = (it == 0 && kin_moves) ? std::span<const Vec3>(kinematic_step_) : std::span<const Vec3>();
    if (it == 0) solve_materials(fs, substep_index, ctx);
    const Index capped = carry_before_detection(fs);
    if (adaptive_reach_ || follow_steps_) set_vertex_reach(it, uniform_next, mask.active(), ctx);
    add_detection(fs, contact_->detect(anchor_, st, ctx));
    join_islands(ctx);
    start_from_materials(fs, mask.active(), capped, ctx);
    SolveResult res;
    {
      ScopedTimer t(fs.times.resolution, fs.times.resolution_serial);
      if (local) std::fill(deferred_marks_.begin(), deferred_marks_.end(), std::uint8_t{0});
      ctx.deferred = deferred_marks_;
      res = contact_->resolve(solve_, anchor_, st, ctx);
      ctx.deferred = {};
    }
    add_resolution(fs, res);
    {
      ScopedTimer check_timer(fs.times.check, fs.times.check_serial);
      next_local = finish_pass(res, t1, local, mask.active(), capped, ctx, end);
    }
    uniform_next = end.remaining > 0 || res.bounded_vertices > 0;
    anchor_.swap(solve_);
    // A solver that guarantees separation does not end a substep on a pass that left pairs inside
    // their offset while passes remain: the next pass starts from there.
    if (end.remaining > 0 && guarantees && it + 1 < bound) continue;
    if (end.held_back == 0) break;  // every vertex reached its intended advance
    if (end.short_enough) break;    // the few held back keep their clamped step (advance_shortfall)
  }
  return end;
}

void Simulation::substep(FrameStats& fs, int substep_index, double dt, int halvings) {
  auto& st = scene_.state;
  const auto& params = scene_.params;
  const auto& tp = params.time;
  const Index nv = st.size();
  const double t1 = st.time + dt;
  ++fs.substeps_run;

  st.x_prev = st.x;
  predicted_.resize(static_cast<size_t>(nv));
  const Vec3 g_dt2 = tp.gravity * dt * dt;
  parallel_for(
      nv,
      [&](Index b, Index e) {
        for (Index i = b; i < e; ++i)
          predicted_[i] = st.inv_mass[i] > 0.0 ? Vec3(st.x[i] + dt * st.v[i] + g_dt2) : st.x[i];
      },
      4096);
  // Rigid bodies repeat their last substep's rigid motion: the linear extrapolation bleeds spin.
  materials_.rigid().predict(st.x, st.v, st.inv_mass, dt, g_dt2, predicted_);
  // Kinematic vertices reach their scripted positions at t1 in the first outer iteration. Their
  // step is known, so the first detection (at the old positions) accounts for it exactly instead
  // of letting a handle or obstacle jump into its neighbours before any region exists.
  const double kin_step = kinematic_targets(t1, predicted_);
  const bool kin_moves = kin_step > 0.0;
  if (kin_step > params.contact.radius * (1.0 + 1e-9) && contact_->clamps_to_radius())
    throw GuaranteeError(frame_ + 1, kinematic_overrun(kin_step));

  halvings_ = halvings;
  StepContext ctx{scene_.topo, params, dt, frame_ + 1, substep_index, 0, fs.times};
  ctx.momentum = params.contact.momentum;
  ctx.tethers = tethers_.empty() ? nullptr : &tethers_;  // the momentum response caps its pushes at them
  // A substep whose passes end with pairs inside their offsets (the run would stop, or warn) is
  // solved once more from its start with contact.momentum's response: typically a vertex between a
  // scripted pusher and a movable one ahead, whose region the paper's fixed dividing plane (half
  // the gap each) leaves empty, and a face of the pusher passes over it. Splitting by the motion
  // passes the push on to the one ahead. Substeps that end clean are untouched.
  contact_->mark_substep();
  PassesEnd end = run_passes(fs, substep_index, t1, kin_moves, ctx);
  if (end.remaining > 0 && contact_->guarantees_separation() && !ctx.momentum) {
    ctx.momentum = true;
    ++fs.substeps_redone;
    end = run_passes(fs, substep_index, t1, kin_moves, ctx);
  }
  // Still inside offsets where the run would stop: solved once more with the pushes of fixed and
  // scripted sides passed on through resting pairs, then, if that is not enough, again as two
  // halves from the substep's start (nothing of the state has moved yet), each with the shorter
  // steps' smaller pushes. Runs that completed before are untouched: these replace stops only.
  if (end.remaining > 0 && stops_on_violation()) {
    ctx.momentum = ctx.push_through = true;
    ++fs.substeps_redone;
    end = run_passes(fs, substep_index, t1, kin_moves, ctx);
  }
  if (end.remaining > 0 && halvings < kSqueezeHalvings && stops_on_violation()) {
    ++fs.substeps_halved;
    --fs.substeps_run;  // the halves count, not the solve they replace
    contact_->rewind_substep();
    substep(fs, substep_index, 0.5 * dt, halvings + 1);
    substep(fs, substep_index, 0.5 * dt, halvings + 1);
    return;
  }
  const double r = params.contact.radius;
  const int bound = tp.iteration_bound();
  const int iterations_run = end.iterations;
  fs.clamped_vertices += end.held_back;
  // Speed capped because the iterations ran out (not by the shortfall rule's choice): say so once.
  if (end.worst && !end.short_enough) report_capped_speed(*end.worst, end.worst_length + (bound - 1) * r, dt);
  fs.violations_remaining = std::max(fs.violations_remaining, end.remaining);
  check_violations(end.remaining, substep_index, iterations_run, end.held_back, fs);
  restore_island_momentum(dt);

  record_lag(fs);

  // v_{n+1} = (x - x_n) / dt, then damping.
  const double keep = std::max(0.0, 1.0 - tp.damping * dt);
  // Copied rather than swapped: positions() keeps one buffer for the simulation's lifetime.
  std::copy(anchor_.begin(), anchor_.end(), st.x.begin());
  parallel_for(
      nv,
      [&](Index b, Index e) {
        for (Index i = b; i < e; ++i) {
          st.v[i] = (st.x[i] - st.x_prev[i]) / dt;
          if (st.inv_mass[i] > 0.0) st.v[i] *= keep;
        }
      },
      4096);
  st.time = t1;
  if (audit_ && params.debug.audit == AuditMode::every_substep) {
    ScopedTimer t(fs.times.audit);
    const Index pen = audit_(st.x);
    fs.penetrations = std::max<Index>(fs.penetrations, 0) + pen;
    check_audit(pen);
  }
}

void Simulation::check_cancel(int substep) const {
  if (cancel_ && cancel_())
    throw FrameInterrupted("frame " + std::to_string(frame_ + 1) + " abandoned in substep " +
                           std::to_string(substep + 1) + " of " + std::to_string(scene_.params.time.substeps));
}

void Simulation::record_lag(FrameStats& fs) const {
  const auto& st = scene_.state;
  const Index nv = st.size();
  // Fixed chunks summed in chunk order: the same stats at any thread count.
  const Index chunks = default_chunk_count(nv);
  std::vector<double> sum(static_cast<size_t>(chunks), 0.0), worst(static_cast<size_t>(chunks), 0.0);
  std::vector<Index> movable(static_cast<size_t>(chunks), 0);
  parallel_chunks(nv, chunks, [&](Index c, Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      if (!(st.inv_mass[i] > 0.0)) continue;
      const double d = (anchor_[i] - material_solved_[i]).norm();
      sum[c] += d;
      worst[c] = std::max(worst[c], d);
      ++movable[c];
    }
  });
  double total = 0.0;
  Index count = 0;
  for (Index c = 0; c < chunks; ++c) {
    total += sum[c];
    count += movable[c];
    fs.lag_max = std::max(fs.lag_max, worst[c]);
  }
  // A running mean over the substeps run so far (substeps_run counts this one).
  const double mean = count > 0 ? total / static_cast<double>(count) : 0.0;
  fs.lag_mean += (mean - fs.lag_mean) / static_cast<double>(fs.substeps_run);
}

void Simulation::check_audit(Index penetrations) {
  if (penetrations <= 0) return;
  const bool fatal = stops_on_violation();
  const std::string what = "the in-simulation audit (debug.audit) found " + std::to_string(penetrations) +
                           " penetration(s) under contact solver '" + std::string(contact_->name()) + "'";
  if (fatal) throw GuaranteeError(frame_ + 1, what + "; stopping before the frame is written");
  log::error("frame {}: {}; continuing (contact.on_violation: warn)", frame_ + 1, what);
}

namespace {
// One value per vertex, all finite: what the state setters accept.
void check_state_array(const Positions& a, size_t n, const char* setter, const char* what) {
  if (a.size() != n)
    throw Error(std::string(setter) + ": " + std::to_string(a.size()) + " rows given, the scene has " +
                std::to_string(n) + " vertices");
  for (size_t i = 0; i < a.size(); ++i)
    if (!a[i].allFinite())
      throw Error(std::string(setter) + ": " + what + " of vertex " + std::to_string(i) + " is not finite");
}
}  // namespace

void Simulation::set_positions(const Positions& x) {
  auto& st = scene_.state;
  check_state_array(x, st.x.size(), "set_positions", "position");
  std::copy(x.begin(), x.end(), st.x.begin());  // in place: views of the buffer stay valid
  st.x_prev = st.x;
  for (size_t k = 0; k < driven_.size(); ++k)
    if (driven_[k]) driven_from_[k] = driven_to_[k] = st.x[kinematic_[k]];
}

void Simulation::set_velocities(const Positions& v) {
  auto& st = scene_.state;
  check_state_array(v, st.v.size(), "set_velocities", "velocity");
  std::copy(v.begin(), v.end(), st.v.begin());
}

void Simulation::set_kinematic_targets(std::span<const Index> vertices, std::span<const Vec3> targets) {
  const auto& topo = scene_.topo;
  if (vertices.size() != targets.size())
    throw Error("set_kinematic_targets: " + std::to_string(vertices.size()) + " vertex indices but " +
                std::to_string(targets.size()) + " targets");
  for (size_t j = 0; j < vertices.size(); ++j) {
    const Index v = vertices[j];
    if (v < 0 || v >= topo.num_vertices())
      throw Error("set_kinematic_targets: vertex index " + std::to_string(v) + " out of range: the scene has " +
                  std::to_string(topo.num_vertices()) + " vertices");
    const Index oi = topo.vertex_object[v];
    const auto& o = topo.objects[oi];
    if (kin_slot_[v] < 0)
      throw Error("set_kinematic_targets: vertex " + std::to_string(v) + " (local " +
                  std::to_string(v - o.vertex_begin) + " of object '" + o.name +
                  "') is neither pinned nor part of an obstacle; pin it in the scene first");
    if (std::find(analytic_obstacles_.begin(), analytic_obstacles_.end(), oi) != analytic_obstacles_.end())
      throw Error("set_kinematic_targets: vertex " + std::to_string(v) + " belongs to obstacle '" + o.name +
                  "', whose analytic shape follows its scripted motion only; set contact.analytic_obstacles: false "
                  "to drive it");
    if (!targets[j].allFinite())
      throw Error("set_kinematic_targets: target " + std::to_string(j) + " (vertex " + std::to_string(v) +
                  ") is not finite");
  }
  if (driven_.empty()) {
    driven_.assign(kinematic_.size(), 0);
    driven_from_.assign(kinematic_.size(), Vec3::Zero());
    driven_to_.assign(kinematic_.size(), Vec3::Zero());
  }
  for (size_t j = 0; j < vertices.size(); ++j) {
    const Index k = kin_slot_[vertices[j]];
    driven_[k] = 1;
    driven_to_[k] = targets[j];
  }
  drive_pending_ = true;
}

FrameStats Simulation::step_frame() {
  Stopwatch wall;
  CpuStopwatch cpu;
  SerialStopwatch serial;
  FrameStats fs;
  const auto& tp = scene_.params.time;
  const double dt = 1.0 / (tp.fps * tp.substeps);
  if (drive_pending_) {
    // New targets are reached over this frame, starting from where the vertices are now.
    for (size_t k = 0; k < driven_.size(); ++k)
      if (driven_[k]) driven_from_[k] = scene_.state.x[kinematic_[k]];
    drive_t0_ = scene_.state.time;
    drive_t1_ = drive_t0_ + 1.0 / tp.fps;
    drive_pending_ = false;
  }
  for (int s = 0; s < tp.substeps; ++s) {
    const int pieces = subdivision(dt);
    for (int k = 0; k < pieces; ++k) {
      check_cancel(s);
      substep(fs, s, dt / pieces);
    }
  }
  ++frame_;
  fs.frame = frame_;
  fs.sim_time = scene_.state.time;
  if (audit_ && scene_.params.debug.audit == AuditMode::every_frame) {
    ScopedTimer t(fs.times.audit);
    fs.penetrations = audit_(scene_.state.x);
    --frame_;  // messages name the frame being computed
    check_audit(fs.penetrations);
    ++frame_;
  }
  fs.wall_s = wall.seconds();
  fs.serial_s = serial.seconds();
  fs.cpu_s = cpu.seconds();
  return fs;
}

}  // namespace ccfr
