// `ogc`: Offset Geometric Contact's conservative per-vertex bounds (Chen et al. 2025, Sec. 4;
// docs/methods.md): each vertex moves at most b_v from where the last detection saw it.
#include "ccfr/solvers/ogc.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <tuple>

#include "../builtin_solvers.hpp"
#include "ccfr/collision/additive_ccd.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"

namespace ccfr {

void OffsetGeometricContactSolver::build_limits(std::span<const double>, std::span<const Vec3> kinematic) {
  const double gp = params_.gamma_p;
  bounds_.assign(centers_.size(), free_bound());
  for (const ContactPair& c : contacts_) {
    const int na = c.side_a(), n = c.size();
    double ka = 0.0, kb = 0.0;  // the largest scripted step on each side
    if (!kinematic.empty())
      for (int k = 0; k < n; ++k) (k < na ? ka : kb) = std::max(k < na ? ka : kb, kinematic[c.v[k]].norm());
    const double b = gp * std::max(0.0, c.distance - c.offset - ka - kb);
    for (int k = 0; k < n; ++k) bounds_[c.v[k]] = std::min(bounds_[c.v[k]], b);
  }
}

bool OffsetGeometricContactSolver::truncate(Index v, Vec3& x) const {
  const Vec3 d = x - centers_[v];
  const double len = d.norm(), b = bounds_[v];
  if (len <= b) return false;
  x = b > 0.0 ? Vec3(centers_[v] + (b / len) * d) : centers_[v];
  return true;
}

bool OffsetGeometricContactSolver::within(Index v, const Vec3& p) const {
  return (p - centers_[v]).norm() <= bounds_[v] * (1.0 + 1e-9) + 1e-14 * centers_[v].cwiseAbs().sum();
}

void register_contact_solver_ogc(ContactSolverRegistry& registry) {
  const TrustRegionParams d;
  registry.add({"ogc",
                "Offset Geometric Contact's conservative per-vertex bounds b_v = γ_p (d_v − ξ), truncation toward "
                "the last detection, re-detection past γ_e (Chen et al. 2025; guarantees separation)",
                trust_region_param_specs(d), [](const ParamValues& v) {
                  return std::make_unique<OffsetGeometricContactSolver>(trust_region_params(v));
                }});
}

}  // namespace ccfr
