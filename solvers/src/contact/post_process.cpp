// `post_process`: the paper's baseline, conventional XPBD thickness constraints on the detected
// pairs inside ξ, solved after the material step by Gauss-Seidel sweeps, with no regions.
#include "ccfr/solvers/post_process.hpp"

#include <tuple>

#include "../builtin_solvers.hpp"
#include "ccfr/solvers/contact_response.hpp"

namespace ccfr {

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

void register_contact_solver_post_process(ContactSolverRegistry& registry) {
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
