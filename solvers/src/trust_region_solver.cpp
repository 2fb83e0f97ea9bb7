// TrustRegionSolver: what `ogc` and `dat` share (Chen et al. 2025): a detection kept while every
// vertex stays inside the limits built from it, truncation toward them, re-detection past γ_e.
#include "ccfr/solvers/trust_region_solver.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>

#include "builtin_solvers.hpp"
#include "ccfr/collision/additive_ccd.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/log.hpp"
#include "ccfr/core/parallel.hpp"

namespace ccfr {

TrustRegionSolver::TrustRegionSolver(TrustRegionParams params) : params_(params) {
  if (!(params_.gamma_p > 0.0 && params_.gamma_p < 0.5) || !(params_.gamma_e >= 0.0 && params_.gamma_e <= 1.0) ||
      !(params_.query_radius >= 0.0))
    throw Error("trust-region contact solver: gamma_p must be in (0, 0.5), gamma_e in [0, 1] and query_radius >= 0");
}

void TrustRegionSolver::initialize(const Topology& topo, const SimState& state, const SimulationParams& params) {
  const std::string key = "contact." + std::string(name());
  for (const auto& o : topo.objects)
    if (o.kind == ObjectKind::rigid)
      throw Error(key + ": rigid object '" + o.name + "' is not supported: '" + std::string(name()) +
                  "' truncates each vertex's step on its own, which would deform a rigid body; use contact.solver "
                  "ccfr or exact_projection (docs/methods.md)");
  offset_ = params.contact.offset;
  feasible_tolerance_ = params.debug.audit_tolerance;
  const double range = params.contact.offset + 2.0 * params.contact.radius;
  query_radius_ = params_.query_radius > 0.0 ? params_.query_radius : range;
  if (!(query_radius_ > offset_) || query_radius_ > range * (1.0 + 1e-12))
    throw Error(
        ccfr::format("{}.query_radius: {} must be > contact.offset ({}) and at most the detection range "
                     "contact.offset + 2 contact.radius ({}); 0 picks the latter",
                     key, params_.query_radius, offset_, range));
  DetectingSolver::initialize(topo, state, params);
  redetect_ = true;
}

DetectResult TrustRegionSolver::detect(const Positions& anchor, const SimState& state, StepContext& ctx) {
  const Index nv = static_cast<Index>(anchor.size());
  bool needed = redetect_ || ctx.iteration == 0 || static_cast<Index>(centers_.size()) != nv;
  if (!needed) {
    // The loop moves anchors after resolve() (obstacle push, rigid carry of isolated objects), and
    // time.continuation frees vertices the last detection saw as fixed: both void the limits.
    for (Index v = 0; v < nv && !needed; ++v)
      if (state.inv_mass[v] > 0.0) needed = !movable_at_detection_[v] || !within(v, anchor[v]);
  }
  if (!needed) return {};
  const DetectResult det = DetectingSolver::detect(anchor, state, ctx);
  ScopedTimer t(ctx.times.narrow,
                ctx.times.narrow_serial);  // building the limits is part of this solver's narrow phase
  centers_ = anchor;
  movable_at_detection_.resize(static_cast<size_t>(nv));
  for (Index v = 0; v < nv; ++v) movable_at_detection_[v] = state.inv_mass[v] > 0.0;
  build_limits(state.inv_mass, ctx.kinematic_step);
  redetect_ = false;
  ++detections_;
  return det;
}

SolveResult TrustRegionSolver::resolve(Positions& x, const Positions&, const SimState& state, StepContext& ctx) {
  const Index nv = static_cast<Index>(x.size());
  if (ctx.frame != halted_frame_ || halted_.size() != x.size()) {
    halted_.assign(x.size(), 0);
    halted_frame_ = ctx.frame;
  }
  truncated_.assign(x.size(), 0);
  const Index chunks = default_chunk_count(nv);
  std::vector<Index> truncated(static_cast<size_t>(chunks), 0), halted(static_cast<size_t>(chunks), 0),
      movable(static_cast<size_t>(chunks), 0);
  parallel_chunks(nv, chunks, [&](Index chunk, Index b, Index e) {
    for (Index v = b; v < e; ++v) {
      if (!(state.inv_mass[v] > 0.0)) continue;
      ++movable[chunk];
      const Vec3 wanted = x[v];
      if (!truncate(v, x[v])) continue;
      ++truncated[chunk];
      truncated_[v] = 1;
      // Wanted to move, stays at its centre: the stall of a zero bound (a resting contact).
      if (x[v] == centers_[v] && wanted != centers_[v]) ++halted[chunk], halted_[v] = 1;
    }
  });
  SolveResult res;
  Index n_movable = 0;
  for (Index c = 0; c < chunks; ++c) {
    res.violations_detected += truncated[c];
    res.halted_vertices += halted[c];
    n_movable += movable[c];
  }
  // OGC's rule: re-detect once more than γ_e of the vertices were truncated; the truncated ones
  // then count as held back, so the loop runs the pass that re-detects.
  redetect_ = static_cast<double>(res.violations_detected) > params_.gamma_e * static_cast<double>(n_movable);
  res.bounded_vertices = redetect_ ? res.violations_detected : 0;
  std::tie(res.contact_vertices, res.contact_vertices_distinct) = mark_contact_vertices(ctx.frame, state.inv_mass);
  res.halted_vertices_distinct = static_cast<Index>(std::count(halted_.begin(), halted_.end(), std::uint8_t{1}));
  // Pairs of the last detection still inside their offset (the loop recounts after its own moves).
  const Index np = static_cast<Index>(contacts_.size());
  const Index pc = default_chunk_count(np);
  std::vector<Index> close(static_cast<size_t>(pc), 0);
  parallel_chunks(np, pc, [&](Index chunk, Index b, Index e) {
    std::array<Vec3, 4> xs;
    for (Index i = b; i < e; ++i) {
      const ContactPair& c = contacts_[i];
      if (separation_lower_bound(c, x) >= c.offset * (1.0 - 1e-9)) continue;
      for (int k = 0; k < 4; ++k) xs[k] = k < c.size() ? x[c.v[k]] : Vec3::Zero();
      if (!(sub_pair_distance(c.kind, xs) >= c.offset * (1.0 - 1e-9))) ++close[chunk];
    }
  });
  for (Index c : close) res.violations_remaining += c;
  return res;
}

std::optional<Index> TrustRegionSolver::count_outside(const Positions& x, const Positions& anchor,
                                                      const SimState& state, StepContext& ctx) const {
  const std::optional<Index> n = DetectingSolver::count_outside(x, anchor, state, ctx);
  if (redetect_ && ctx.violated.size() == truncated_.size())
    for (size_t v = 0; v < truncated_.size(); ++v) ctx.violated[v] |= truncated_[v];
  return n;
}

std::vector<ParamSpec> trust_region_param_specs(const TrustRegionParams& d) {
  return {ParamSpec::number("gamma_p", d.gamma_p,
                            "γ_p: share of a pair's gap beyond its offset that each side may move per detection "
                            "(< 1/2: both sides together keep the offset)",
                            0.0, 0.5, true, true),
          ParamSpec::number("gamma_e", d.gamma_e,
                            "γ_e: re-detect, and run another outer iteration, once more than this share of the "
                            "movable vertices was truncated in a pass",
                            0.0, 1.0),
          ParamSpec::number("query_radius", d.query_radius,
                            "r_q in metres: pairs beyond it give no bound of their own and every vertex moves at most "
                            "γ_p (r_q − ξ) per detection; at most ξ + 2r, the detection range; 0 picks ξ + 2r",
                            0.0)};
}

TrustRegionParams trust_region_params(const ParamValues& v) {
  TrustRegionParams p;
  p.gamma_p = v.number("gamma_p");
  p.gamma_e = v.number("gamma_e");
  p.query_radius = v.number("query_radius");
  return p;
}

}  // namespace ccfr
