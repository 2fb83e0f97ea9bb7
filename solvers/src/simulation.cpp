#include "ccfr/solvers/simulation.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/solvers/obstacles.hpp"

namespace ccfr {


Simulation::Simulation(Scene scene) : scene_(std::move(scene)) {
  const auto& topo = scene_.topo;
  auto& st = scene_.state;
  const auto& params = scene_.params;
  contact_ = make_contact_solver(params.contact.solver);

  // Material constraints of every object kind (docs/materials.md); coloured with the final pins.
  materials_ = MaterialSystem(topo, st, params);

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
    if (op.shape.type != AnalyticShape::Type::none) analytic_obstacles_.push_back(static_cast<Index>(oi));
  }
  for (Index v = 0; v < topo.num_vertices(); ++v)
    if (is_kin[v]) {
      kinematic_.push_back(v);
      kin_motion_.push_back(motion_of[v] && motion_of[v]->moves() ? motion_of[v] : nullptr);
    }
  contact_->initialize(topo, st, params);
  check_finite(st.x, "initial state");
  const auto mc = materials_.counts();
  spdlog::info("scene '{}': {} objects, {} vertices, {} faces, {} edges, {} tets; constraints: {} distance, {} bending, "
               "{} strand bending, {} tet, {} rigid bodies ({} colours); {} kinematic vertices; contact solver '{}'",
               params.scene_name, topo.objects.size(), topo.num_vertices(), topo.num_faces(), topo.num_edges(), topo.tets.size(),
               mc.distance, mc.bending, mc.strand_bending, mc.tet_volume, mc.rigid_bodies, mc.colours, kinematic_.size(),
               contact_->name());
}

Simulation::~Simulation() = default;

double Simulation::kinematic_targets(double t, Positions& target) {
  const auto& st = scene_.state;
  kinematic_step_.assign(st.x.size(), Vec3::Zero());
  double largest = 0.0;
  for (size_t k = 0; k < kinematic_.size(); ++k) {
    if (!kin_motion_[k]) continue;
    const Index v = kinematic_[k];
    target[v] = kin_motion_[k]->apply(st.rest[v], t);
    kinematic_step_[v] = target[v] - st.x[v];
    largest = std::max(largest, kinematic_step_[v].norm());
  }
  return largest;
}

void Simulation::check_finite(const Positions& x, const char* stage) const {
  std::atomic<Index> first{std::numeric_limits<Index>::max()};
  parallel_for(static_cast<Index>(x.size()), [&](Index b, Index e) {
    for (Index i = b; i < e; ++i)
      if (!x[i].allFinite()) {
        Index cur = first.load();
        while (i < cur && !first.compare_exchange_weak(cur, i)) {
        }
        return;
      }
  }, 4096);
  if (first.load() != std::numeric_limits<Index>::max()) throw NumericalError(frame_ + 1, first.load(), stage);
}

void Simulation::collide_analytic(Positions& x, double t) const {
  if (analytic_obstacles_.empty() || !scene_.params.contact.analytic_obstacles) return;
  const auto& st = scene_.state;
  const double offset = scene_.params.contact.offset;
  parallel_for(static_cast<Index>(x.size()), [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      if (st.inv_mass[i] == 0.0) continue;
      for (Index oi : analytic_obstacles_) {
        const auto& op = scene_.params.objects[oi];
        Vec3 n;
        const double d = analytic_sdf(op.shape, op.motion, t, x[i], n);
        if (d < offset) x[i] += (offset - d) * n;
      }
    }
  }, 1024);
}

void Simulation::substep(FrameStats& fs, int substep_index) {
  auto& st = scene_.state;
  const auto& params = scene_.params;
  const auto& tp = params.time;
  const Index nv = st.size();
  const double dt = 1.0 / (tp.fps * tp.substeps);
  const double t1 = st.time + dt;

  st.x_prev = st.x;
  predicted_.resize(static_cast<size_t>(nv));
  const Vec3 g_dt2 = tp.gravity * dt * dt;
  parallel_for(nv, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i)
      predicted_[i] = st.inv_mass[i] > 0.0 ? Vec3(st.x[i] + dt * st.v[i] + g_dt2) : st.x[i];
  }, 4096);
  // Kinematic vertices reach their scripted positions at t1 in the first outer iteration. Their
  // step is known, so the first detection (at the old positions) accounts for it exactly instead
  // of letting a handle or obstacle jump into its neighbours before any region exists.
  const double kin_step = kinematic_targets(t1, predicted_);
  const bool kin_moves = kin_step > 0.0;
  if (kin_step > params.contact.radius && !warned_kinematic_step_ && contact_->clamps_to_radius()) {
    warned_kinematic_step_ = true;
    spdlog::warn("kinematic vertices move up to {:.3g} per substep, more than the search radius r = {:.3g}: pairs farther "
                 "than 2r may be reached unseen; raise time.substeps",
                 kin_step, params.contact.radius);
  }

  anchor_ = st.x;
  StepContext ctx{scene_.topo, params, dt, frame_ + 1, substep_index, 0, fs.times};
  const double r = params.contact.radius;
  Index remaining = 0;
  for (int it = 0; it < tp.iterations; ++it) {
    ctx.iteration = it;
    ctx.kinematic_step = (it == 0 && kin_moves) ? std::span<const Vec3>(kinematic_step_) : std::span<const Vec3>();
    const DetectionSummary det = contact_->detect(anchor_, st, ctx);
    fs.candidates = std::max(fs.candidates, det.candidates);
    fs.constraints = std::max(fs.constraints, det.constraints);
    fs.min_distance = std::min(fs.min_distance, det.min_distance);

    // Solve from the prediction (design clarification 6), fresh multipliers each outer iteration.
    solve_ = predicted_;
    {
      ScopedTimer t(fs.times.xpbd);
      materials_.reset_multipliers();
      for (int s = 0; s < tp.xpbd_sweeps; ++s) materials_.solve(solve_, st.inv_mass, dt);
      check_finite(solve_, "xpbd");
      contact_->respond(solve_, anchor_, st, ctx);
      check_finite(solve_, "contact response");
    }
    SolveResult res;
    {
      ScopedTimer t(fs.times.resolution);
      res = contact_->resolve(solve_, anchor_, st, ctx);
      collide_analytic(solve_, t1);
      check_finite(solve_, "contact resolution");
    }
    fs.violations_detected += res.violations_detected;
    fs.halted_vertices += res.halted_vertices;
    remaining = res.violations_remaining;
    ++fs.outer_iterations;

    // Step bound: no vertex moves farther than r from its anchor in one outer iteration, so
    // primitives not seen by this iteration's detection cannot be reached (paper Alg. line 16).
    Index clamped = 0;
    if (contact_->clamps_to_radius()) {
      std::atomic<Index> count{0};
      parallel_for(nv, [&](Index b, Index e) {
        Index local = 0;
        for (Index i = b; i < e; ++i) {
          if (st.inv_mass[i] == 0.0) continue;  // scripted motion is not bounded by r
          const Vec3 d = solve_[i] - anchor_[i];
          const double len = d.norm();
          if (len > r) {
            solve_[i] = anchor_[i] + (r / len) * d;
            if (len > r * (1.0 + tp.advance_tolerance)) ++local;
          }
        }
        count += local;
      }, 4096);
      clamped = count.load();
    }
    fs.clamped_vertices += clamped;
    {
      // What the substep really ends with, after the clamp and the analytic push.
      ScopedTimer t(fs.times.resolution);
      const Index recount = contact_->count_outside(solve_, anchor_, st, ctx);
      if (recount >= 0) remaining = recount;
    }
    anchor_.swap(solve_);
    if (clamped == 0) break;  // every vertex reached its intended advance
  }
  fs.violations_remaining = std::max(fs.violations_remaining, remaining);

  // v_{n+1} = (x - x_n) / dt, then damping.
  const double keep = std::max(0.0, 1.0 - tp.damping * dt);
  st.x.swap(anchor_);
  parallel_for(nv, [&](Index b, Index e) {
    for (Index i = b; i < e; ++i) {
      st.v[i] = (st.x[i] - st.x_prev[i]) / dt;
      if (st.inv_mass[i] > 0.0) st.v[i] *= keep;
    }
  }, 4096);
  st.time = t1;
  if (audit_ && params.debug.audit == AuditMode::every_substep) {
    ScopedTimer t(fs.times.audit);
    fs.penetrations = std::max<Index>(fs.penetrations, 0) + audit_(st.x);
  }
}

FrameStats Simulation::step_frame() {
  Stopwatch wall;
  FrameStats fs;
  for (int s = 0; s < scene_.params.time.substeps; ++s) substep(fs, s);
  ++frame_;
  fs.frame = frame_;
  fs.sim_time = scene_.state.time;
  if (audit_ && scene_.params.debug.audit == AuditMode::every_frame) {
    ScopedTimer t(fs.times.audit);
    fs.penetrations = audit_(scene_.state.x);
  }
  fs.wall_s = wall.seconds();
  return fs;
}

}  // namespace ccfr
