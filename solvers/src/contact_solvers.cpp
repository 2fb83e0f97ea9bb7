#include "ccfr/solvers/contact_solvers.hpp"

#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"

#include <atomic>

namespace ccfr {

void DetectingSolver::initialize(const Topology& topo, const SimState& state, const SimulationParams& params) {
  const CollisionParams cp{params.contact.radius, params.contact.offset, params.contact.repulsion_range};
  detector_ = std::make_unique<CollisionDetector>(topo, state.x, cp, make_broad_phase(params.collision.broad_phase));
  regions_.clear(topo.num_vertices());
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

DetectionSummary DetectingSolver::detect(const Positions& anchor, const SimState& state, StepContext& ctx) {
  DetectionStats ds;
  detector_->detect(anchor, state.inv_mass, regions_, contacts_, ds, ctx.kinematic_step);
  ctx.times.broad += ds.broad_s;
  ctx.times.narrow += ds.narrow_s;
  {
    ScopedTimer t(ctx.times.narrow);  // contact bookkeeping for the response belongs to the narrow phase
    response_.prepare(contacts_, state.size(), ctx.params.contact);
  }
  DetectionSummary s;
  s.candidates = ds.candidates;
  s.constraints = ds.constraints;
  for (const auto& c : contacts_) s.min_distance = std::min(s.min_distance, c.distance);
  return s;
}

void DetectingSolver::respond(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx) {
  response_.apply(x, state.x_prev, state.inv_mass, ctx.params.contact, ctx.dt, friction_override_);
}

RegionProjectionSolver::RegionProjectionSolver(std::string solver_name, std::string projector_name)
    : name_(std::move(solver_name)), projector_name_(std::move(projector_name)) {}

void RegionProjectionSolver::initialize(const Topology& topo, const SimState& state, const SimulationParams& params) {
  DetectingSolver::initialize(topo, state, params);
  ProjectorParams pp;
  pp.epsilon = params.contact.epsilon;
  pp.max_iterations = params.contact.max_projection_iterations;
  pp.redundancy_tolerance = params.contact.redundancy_tolerance;
  pp.sweeps = params.contact.projection_sweeps;
  projector_ = make_projector(projector_name_, pp);
}

SolveResult RegionProjectionSolver::resolve(Positions& x, const Positions& anchor, const SimState& state, StepContext&) {
  const BatchStats b = project_all(*projector_, regions_, anchor, x, state.inv_mass);
  SolveResult r;
  r.violations_detected = b.violated;
  r.violations_remaining = b.remaining;
  r.halted_vertices = b.halted;
  return r;
}

Index RegionProjectionSolver::count_outside(const Positions& x, const Positions& anchor, const SimState& state,
                                           StepContext&) const {
  std::atomic<Index> outside{0};
  parallel_for(regions_.num_vertices(), [&](Index b, Index e) {
    Index local = 0;
    for (Index v = b; v < e; ++v)
      if (state.inv_mass[v] > 0.0 && regions_.count(v) > 0 && min_value(anchor[v], x[v], regions_.of(v)) < -1e-9) ++local;
    outside += local;
  }, 1024);
  return outside.load();
}

Index PostProcessSolver::count_outside(const Positions& x, const Positions&, const SimState&, StepContext& ctx) const {
  Index n = 0;
  for (const auto& c : contacts_)
    if (contact_gap(c, x, ctx.params.contact.offset) < -1e-9) ++n;
  return n;
}

SolveResult PostProcessSolver::resolve(Positions& x, const Positions&, const SimState& state, StepContext& ctx) {
  const auto& p = ctx.params.contact;
  const auto& w = state.inv_mass;
  SolveResult r;
  for (const auto& c : contacts_)
    if (contact_gap(c, x, p.offset) < 0.0) ++r.violations_detected;
  // Sequential Gauss-Seidel: this is the conventional pass the paper compares against, whose
  // order dependence is part of what the comparison shows.
  for (int sweep = 0; sweep < p.projection_sweeps; ++sweep) {
    bool any = false;
    for (const auto& c : contacts_) {
      const double gap = contact_gap(c, x, p.offset);
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
    if (contact_gap(c, x, p.offset) < -1e-9) ++r.violations_remaining;
  return r;
}

}  // namespace ccfr
