#include "ccfr/solvers/toi_clamp.hpp"

#include "../builtin_solvers.hpp"
#include "ccfr/solvers/step_bound.hpp"

#include <algorithm>
#include <cmath>

#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/distance.hpp"

namespace ccfr {

TimeOfImpactClampSolver::TimeOfImpactClampSolver(ToiClampParams params) : params_(params) {
  if (!(params_.scale > 0.0 && params_.scale <= 1.0) || params_.max_iterations < 1 || !(params_.touch_tolerance >= 0.0))
    throw Error("toi_clamp: scale must be in (0, 1], max_iterations >= 1 and touch_tolerance >= 0");
}

SolveResult TimeOfImpactClampSolver::resolve(Positions& x, const Positions& anchor, const SimState& state,
                                             StepContext& ctx) {
  const double r = ctx.params.contact.radius;
  const Index nv = static_cast<Index>(x.size());

  // Path ends: the candidates under the step bound r, with the same expression as the substep
  // loop's clamp, so that leaving x untouched at t* = 1 ends exactly at e.
  apply_step_bound(x, anchor, state.inv_mass, r, ctx.params.time.advance_tolerance, end_);

  // Times of impact with a per-chunk minimum; min and counts are order-independent, so the result
  // is the same for any thread count.
  const Index np = static_cast<Index>(contacts_.size());
  const Index chunks = default_chunk_count(np);
  std::vector<double> chunk_min(static_cast<size_t>(chunks), 1.0);
  std::vector<Index> chunk_hits(static_cast<size_t>(chunks), 0);
  if (np > 0)
    parallel_chunks(np, chunks, [&](Index chunk, Index b, Index e) {
      double tmin = 1.0;
      Index hits = 0;
      std::array<Vec3, 4> x0, x1;
      for (Index c = b; c < e; ++c) {
        const ContactPair& cp = contacts_[c];
        const int n = cp.size();
        for (int k = 0; k < 4; ++k) {
          x0[k] = k < n ? anchor[cp.v[k]] : Vec3::Zero();
          x1[k] = k < n ? end_[cp.v[k]] : Vec3::Zero();
        }
        const AccdResult a = additive_ccd(cp.kind, x0, x1, cp.offset, params_);
        if (a.toi < 1.0) ++hits;
        tmin = std::min(tmin, a.toi);
      }
      chunk_min[chunk] = tmin;
      chunk_hits[chunk] = hits;
    });
  double t_star = 1.0;
  SolveResult res;
  res.contact_vertices = contact_vertex_count(state.inv_mass);
  for (Index c = 0; c < chunks; ++c) {
    t_star = std::min(t_star, chunk_min[c]);
    res.violations_detected += chunk_hits[c];
  }

  // Lu et al. interpolate the whole system, not just the pairs in contact.
  if (t_star < 1.0) {
    std::vector<Index> moved_before(static_cast<size_t>(default_chunk_count(nv)), 0);
    parallel_chunks(nv, default_chunk_count(nv), [&](Index chunk, Index b, Index e) {
      Index halted = 0;
      for (Index i = b; i < e; ++i) {
        if (state.inv_mass[i] > 0.0 && x[i] != anchor[i]) ++halted;
        x[i] = anchor[i] + t_star * (end_[i] - anchor[i]);
      }
      moved_before[chunk] = halted;
    });
    if (t_star == 0.0)
      for (Index h : moved_before) res.halted_vertices += h;
  }

  // Audit of the result at the positions the substep will keep (x, or e after the loop's clamp).
  const Positions& final_x = t_star < 1.0 ? x : end_;
  std::vector<Index> chunk_close(static_cast<size_t>(chunks), 0);
  if (np > 0)
    parallel_chunks(np, chunks, [&](Index chunk, Index b, Index e) {
      Index close = 0;
      std::array<Vec3, 4> xs;
      for (Index c = b; c < e; ++c) {
        const ContactPair& cp = contacts_[c];
        const int n = cp.size();
        for (int k = 0; k < 4; ++k) xs[k] = k < n ? final_x[cp.v[k]] : Vec3::Zero();
        if (sub_pair_distance(cp.kind, xs) < cp.offset * (1.0 - 1e-9)) ++close;
      }
      chunk_close[chunk] = close;
    });
  for (Index c : chunk_close) res.violations_remaining += c;
  return res;
}

void register_contact_solver_toi_clamp(ContactSolverRegistry& registry) {
  const ToiClampParams d;  // the specs' defaults are the struct's
  registry.add({"toi_clamp",
                "time-of-impact clamp of the whole system along a -> x with Additive CCD (Lu et al. 2023 baseline)",
                {ParamSpec::number("scale", d.scale,
                                   "s: each advancement covers this fraction of what the distance bound allows", 0.0,
                                   1.0, true, false),
                 ParamSpec::integer("max_iterations", d.max_iterations,
                                    "advancement steps per pair before giving up with the (safe) time reached", 1),
                 ParamSpec::number("touch_tolerance", d.touch_tolerance,
                                   "a pair whose gap d - ξ is at most this fraction of ξ counts as touching (toi = 0)",
                                   0.0, 1.0)},
                [](const ParamValues& v) {
                  ToiClampParams p;
                  p.scale = v.number("scale");
                  p.max_iterations = static_cast<int>(v.integer("max_iterations"));
                  p.touch_tolerance = v.number("touch_tolerance");
                  return std::make_unique<TimeOfImpactClampSolver>(p);
                }});
}

}  // namespace ccfr
