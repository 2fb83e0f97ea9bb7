#include "ccfr/solvers/dat.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "../builtin_solvers.hpp"
#include "ccfr/feasibility/projector.hpp"
#include "ccfr/feasibility/region.hpp"

namespace ccfr {

void DivideAndTruncateSolver::build_limits(std::span<const double> inv_mass, std::span<const Vec3> kinematic) {
  const double two_gp = 2.0 * params_.gamma_p;
  const size_t nv = centers_.size();
  // Two sweeps over the contacts (count, then fill) into a CSR by vertex, in contact order.
  row_start_.assign(nv + 1, 0);
  for (const ContactPair& c : contacts_)
    for (int k = 0; k < c.size(); ++k)
      if (inv_mass[c.v[k]] > 0.0) ++row_start_[static_cast<size_t>(c.v[k]) + 1];
  for (size_t v = 0; v < nv; ++v) row_start_[v + 1] += row_start_[v];
  limits_.resize(static_cast<size_t>(row_start_[nv]));
  std::vector<Index> cursor(row_start_.begin(), row_start_.end() - 1);
  for (const ContactPair& c : contacts_) {
    const int na = c.side_a(), n = c.size();
    // The gap along n: side A's lowest and side B's highest vertex, a scripted vertex at both
    // ends of its straight step (n·x is linear along it).
    // The same over the vertices that cannot move (scripted or fixed), which no limit can hold.
    const double inf = std::numeric_limits<double>::infinity();
    double lo_a = inf, hi_b = -inf, lo_a_fixed = inf, hi_b_fixed = -inf, lo_a_now = inf, hi_b_now = -inf;
    for (int k = 0; k < n; ++k) {
      const Vec3& p = centers_[c.v[k]];
      double s0 = c.n.dot(p), s1 = s0;
      if (!kinematic.empty()) s1 = c.n.dot(p + kinematic[c.v[k]]);
      const bool fixed = !(inv_mass[c.v[k]] > 0.0);
      if (k < na) {
        lo_a = std::min({lo_a, s0, s1});
        lo_a_now = std::min(lo_a_now, s0);
        if (fixed) lo_a_fixed = std::min({lo_a_fixed, s0, s1});
      } else {
        hi_b = std::max({hi_b, s0, s1});
        hi_b_now = std::max(hi_b_now, s0);
        if (fixed) hi_b_fixed = std::max({hi_b_fixed, s0, s1});
      }
    }
    // The middle of the gap; where the gap is below ξ_c (a push), moved so that the immovable
    // vertices already meet their side's bound and the movable side takes the whole push.
    double mid = 0.5 * (lo_a + hi_b);
    const double lowest = hi_b_fixed + 0.5 * c.offset, highest = lo_a_fixed - 0.5 * c.offset;
    if (lowest <= highest) mid = std::clamp(mid, lowest, highest);
    // A push only where the pair needs one: its distance, less what the scripted steps close along
    // n, below what the audit counts as clean. Otherwise ℓ_A − h_B below ξ_c is the normal's error
    // (its rounding times a 0.4 m table's corners: 1e-14; an edge-edge pair's inexact closest
    // points: up to 6e-10 on the card stack), and a limit past a feasible centre breaks the ray
    // fallback (it then skips that limit).
    const double closed = (lo_a_now - hi_b_now) - (lo_a - hi_b);
    const bool push = c.distance - closed < c.offset * (1.0 - feasible_tolerance_);
    for (int k = 0; k < n; ++k) {
      const Index u = c.v[k];
      if (!(inv_mass[u] > 0.0)) continue;
      const bool a = k < na;
      DivisionLimit l;
      l.normal = a ? c.n : Vec3(-c.n);
      const double own = l.normal.dot(centers_[u]);  // where u is, along its own side's normal
      const double bound = a ? mid + 0.5 * c.offset : -(mid - 0.5 * c.offset);  // how far it may come
      // Beyond the bound already (a scripted side's known step moved the plane past it, or the
      // pair starts inside its offset): the limit is the bound itself, so the cut pushes u out
      // along ν, as CCFR's half-space with a known Δx_B does. Without a push: u's centre, which
      // keeps the pair's gap along n as it is.
      l.limit = own >= bound ? own - two_gp * (own - bound) : (push ? bound : own);
      limits_[static_cast<size_t>(cursor[u]++)] = l;
    }
  }
}

bool DivideAndTruncateSolver::truncate_against(const Vec3& c, std::span<const DivisionLimit> limits, double ball,
                                               Vec3& x) {
  Vec3 y = x;
  // `margin` ulps of slack: removing a normal component leaves n·y a rounding off the limit, and
  // a resting vertex (limit at its centre) must not be sent back to the centre for that.
  auto crosses = [&](const Vec3& p, double margin) {
    for (const DivisionLimit& l : limits)
      if (l.normal.dot(p) <
          l.limit - margin * std::numeric_limits<double>::epsilon() * (p.cwiseAbs().sum() + std::abs(l.limit)))
        return true;
    return false;
  };
  if (crosses(y, 0.0)) {
    // Only the normal component past each limit goes; for one plane (or orthogonal ones) this is
    // the projection onto the allowed set, so the tangential motion survives.
    for (int sweep = 0; sweep < 4; ++sweep) {
      bool any = false;
      for (const DivisionLimit& l : limits) {
        const double s = l.normal.dot(y) - l.limit;
        if (s < 0.0) y -= s * l.normal, any = true;
      }
      if (!any) break;
    }
    if (crosses(y, 8.0)) {
      // Oblique planes the sweeps did not settle (or rounding): back along the ray to the centre,
      // which satisfies every limit, to the first one reached. Where a push put a limit past the
      // centre, the ray starts instead from the nearest point that meets every limit (the exact
      // projection of the centre, a small QP; rare): from the centre, the sweeps' last crossing of
      // the pushed limit would stay (4.7e-6 ξ per pass for a card squeezed on the table).
      Vec3 o = c;
      if (crosses(c, 8.0)) {
        std::vector<HalfSpace> planes;
        planes.reserve(limits.size());
        for (const DivisionLimit& l : limits) planes.push_back({l.normal, l.normal.dot(c) - l.limit});
        ProjectorParams pp;
        pp.epsilon = 0.0;  // no retraction toward the centre, which is outside
        const ProjectResult r = make_projector("exact", pp)->project(c, c, planes);
        if (r.status != ProjectStatus::infeasible && r.x.allFinite() && !crosses(r.x, 8.0)) o = r.x;
      }
      double t = 1.0;
      for (const DivisionLimit& l : limits) {
        const double at_o = l.normal.dot(o) - l.limit, at_y = l.normal.dot(y) - l.limit;
        // A limit the origin itself crosses (a push whose limits admit no point) cannot be met
        // along this ray: left to the sweeps.
        if (at_y < 0.0 && at_o >= 0.0) t = std::min(t, at_o > 0.0 ? at_o / (at_o - at_y) : 0.0);
      }
      y = o + t * (y - o);
      if (crosses(y, 8.0) && !crosses(o, 8.0)) y = o;  // t rounded past a limit: the origin is allowed
    }
  }
  // The isotropic fallback for what lies beyond the query radius.
  const Vec3 d = y - c;
  const double len = d.norm();
  if (len > ball) y = ball > 0.0 ? Vec3(c + (ball / len) * d) : c;
  if (y == x) return false;
  x = y;
  return true;
}

bool DivideAndTruncateSolver::truncate(Index v, Vec3& x) const {
  return truncate_against(centers_[v], limits(v), free_bound(), x);
}

bool DivideAndTruncateSolver::within(Index v, const Vec3& p) const {
  const double slack = 1e-14 * (centers_[v].cwiseAbs().sum() + p.cwiseAbs().sum());
  if ((p - centers_[v]).norm() > free_bound() * (1.0 + 1e-9) + slack) return false;
  for (const DivisionLimit& l : limits(v))
    if (l.normal.dot(p) < l.limit - slack) return false;
  return true;
}

void register_contact_solver_dat(ContactSolverRegistry& registry) {
  const TrustRegionParams d;
  registry.add({"dat",
                "planar Divide-and-Truncate: one division plane per detected pair at the middle of its gap, each "
                "vertex's step truncated only along the planes' normals, OGC's re-detection (guarantees separation)",
                trust_region_param_specs(d), [](const ParamValues& v) {
                  return std::make_unique<DivideAndTruncateSolver>(trust_region_params(v));
                }});
}

}  // namespace ccfr
