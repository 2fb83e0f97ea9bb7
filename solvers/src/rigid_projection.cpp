#include "ccfr/solvers/rigid_projection.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>

#include "ccfr/core/parallel.hpp"
#include "ccfr/geometry/mass_properties.hpp"
#include "ccfr/solvers/materials.hpp"

namespace ccfr {

namespace {

/// A constraint value below this counts as outside (the recount's tolerance).
constexpr double kOutside = -1e-9;
/// Refit iterations before the line search: project, fit, re-check.
constexpr int kRefitIterations = 3;
/// Halvings of the line search after the linear-blend bound.
constexpr int kLineSearchHalvings = 12;

struct Pose {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
  Vec3 c = Vec3::Zero();
};

/// Best rigid fit (weighted centre, polar rotation of A_pq; Müller et al. 2005). A core of mass
/// `core` at `core_at` (the centre of the pose the corrections started from) joins the centre only:
/// corrections Δᵢ then move the centre by Σ mᵢΔᵢ / (Σ mᵢ + core) and turn the body by
/// I⁻¹ Σ qᵢ × mᵢΔᵢ to first order, I = tr(S) 1 - S, S = Σ mᵢ qᵢqᵢᵀ: a rigid body's impulse response.
Pose fit(std::span<const Vec3> x, std::span<const Vec3> rest, std::span<const double> m, double core = 0.0,
         const Vec3& core_at = Vec3::Zero()) {
  double total = core;
  Vec3 c = core * core_at;
  for (size_t i = 0; i < x.size(); ++i) {
    total += m[i];
    c += m[i] * x[i];
  }
  c /= total;
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  for (size_t i = 0; i < x.size(); ++i) a.noalias() += m[i] * (x[i] - c) * rest[i].transpose();
  Pose p;
  p.c = c;
  p.q = Eigen::Quaterniond(xpbd::polar_rotation(a));
  p.q.normalize();
  return p;
}

}  // namespace

RigidBodies::RigidBodies(const Topology& topo, const SimState& state, const SimulationParams* params) {
  const bool with_cores = params && params->objects.size() == topo.objects.size();
  for (size_t oi = 0; oi < topo.objects.size(); ++oi) {
    const auto& o = topo.objects[oi];
    if (o.kind != ObjectKind::rigid || o.num_vertices() == 0) continue;
    Body b;
    b.begin = o.vertex_begin;
    b.end = o.vertex_end;
    double max_mass = 0.0;
    for (Index v = b.begin; v < b.end; ++v) {
      b.kinematic.push_back(!(state.inv_mass[v] > 0.0));
      if (state.inv_mass[v] > 0.0)
        max_mass = std::max(max_mass, 1.0 / state.inv_mass[v]);
      else
        b.pinned = true;
    }
    const double kinematic_weight = max_mass > 0.0 ? 1e9 * max_mass : 1.0;
    double total = 0.0;
    Vec3 centre = Vec3::Zero();
    for (Index v = b.begin; v < b.end; ++v) {
      const double m = state.inv_mass[v] > 0.0 ? 1.0 / state.inv_mass[v] : kinematic_weight;
      b.weight.push_back(m);
      total += m;
      centre += m * state.rest[v];
    }
    centre /= total;
    for (Index v = b.begin; v < b.end; ++v) {
      b.rest.push_back(state.rest[v] - centre);
      b.extent = std::max(b.extent, b.rest.back().norm());
    }
    if (with_cores && !b.pinned) {
      std::vector<Vec3i> faces;
      for (Index f = o.face_begin; f < o.face_end; ++f) faces.push_back(topo.faces[f] - Vec3i::Constant(b.begin));
      const double solid =
          params->objects[oi].material.density *
          solid_mass_properties(std::span<const Vec3>(state.rest.data() + b.begin, b.rest.size()), faces).volume;
      if (solid > total * (1.0 + 1e-12)) b.core = solid - total;
    }
    bodies_.push_back(std::move(b));
  }
}

std::vector<Vec3> RigidBodies::predicted_cores(const SimState& state, double dt, const Vec3& gravity) const {
  std::vector<Vec3> out(bodies_.size(), Vec3::Zero());
  for (size_t bi = 0; bi < bodies_.size(); ++bi) {
    const Body& b = bodies_[bi];
    double total = 0.0;
    Vec3 c = Vec3::Zero(), v = Vec3::Zero();
    for (size_t i = 0; i < b.rest.size(); ++i) {
      total += b.weight[i];
      c += b.weight[i] * state.x[b.begin + static_cast<Index>(i)];
      v += b.weight[i] * state.v[b.begin + static_cast<Index>(i)];
    }
    // The weighted centre is the solid's centre of mass, and Σ mᵢvᵢ / Σ mᵢ its velocity.
    out[bi] = (c + dt * v) / total + gravity * dt * dt;
  }
  return out;
}

RigidEnforceStats RigidBodies::enforce(Positions& x, const Positions& anchor, const RegionSet& regions,
                                       const Projector& projector, double step_bound, double advance_tolerance,
                                       std::span<const Vec3> cores) const {
  std::vector<RigidEnforceStats> per(bodies_.size());
  parallel_for(
      size(),
      [&](Index lo, Index hi) {
        std::vector<Vec3> y;
        for (Index bi = lo; bi < hi; ++bi) {
          const Body& b = bodies_[bi];
          RigidEnforceStats& st = per[bi];
          const size_t n = b.rest.size();
          const std::span<const Vec3> rest(b.rest);
          auto place = [&](const Pose& p, std::vector<Vec3>& out) {
            const Eigen::Matrix3d r = p.q.toRotationMatrix();
            out.resize(n);
            for (size_t i = 0; i < n; ++i) out[i] = r * b.rest[i] + p.c;
          };
          // Largest violation of the regions and the step bound; >= 0 means admissible.
          auto admissible = [&](const std::vector<Vec3>& p, bool& by_bound_only) {
            bool region_ok = true, bound_ok = true;
            for (size_t i = 0; i < n; ++i) {
              const Index v = b.begin + static_cast<Index>(i);
              if (falls_below(anchor[v], p[i], regions.of(v), kOutside)) region_ok = false;
              if (!((p[i] - anchor[v]).norm() <= step_bound * (1.0 + 1e-12))) bound_ok = false;
              if (!region_ok) break;
            }
            by_bound_only = region_ok && !bound_ok;
            return region_ok && bound_ok;
          };
          const std::span<Vec3> xb(x.data() + b.begin, n);
          const double core = cores.empty() ? 0.0 : b.core;
          Pose target = fit(xb, rest, b.weight, core, cores.empty() ? Vec3::Zero() : cores[bi]);
          if (b.pinned) {  // pins decide the pose; only the dynamic vertices move
            place(target, y);
            for (size_t i = 0; i < n; ++i)
              if (!b.kinematic[i]) xb[i] = y[i];
            ++st.bodies_refitted;
            continue;
          }
          bool bounded = false;
          bool ok = false;
          // Whether the step bound, not a region, shortened the body's step (by more than the
          // substep's advance tolerance): the substep must then iterate on, or it caps the body's
          // speed at r per substep without a word (a 30 m/s projectile fell at 2.4 m/s).
          bool held_by_bound = false;
          for (int it = 0; it < kRefitIterations && !ok; ++it) {
            place(target, y);
            ok = admissible(y, bounded);
            if (ok) break;
            // Project the fitted positions vertex by vertex, hold them within the step bound, refit.
            for (size_t i = 0; i < n; ++i) {
              const Index v = b.begin + static_cast<Index>(i);
              if (regions.count(v) > 0) y[i] = projector.project(anchor[v], y[i], regions.of(v)).x;
              const Vec3 d = y[i] - anchor[v];
              const double len = d.norm();
              if (len > step_bound) {
                held_by_bound = held_by_bound || len > step_bound * (1.0 + advance_tolerance);
                y[i] = anchor[v] + (step_bound / len) * d;
              }
              if (!y[i].allFinite()) y[i] = anchor[v];
            }
            target = fit(y, rest, b.weight, core, target.c);  // the core moves with the pose it refines
          }
          ++st.bodies_refitted;
          if (ok) {
            std::copy(y.begin(), y.end(), xb.begin());
            if (held_by_bound) ++st.bodies_bounded;
            continue;
          }
          // Line search along the rigid interpolation from the anchor pose (slerp, lerp). The bound
          // of the linear blend anchor + α (y - anchor) is exact per half-space and per step-bound
          // ball (both convex, both hold at α = 0); the rigid pose at that α is then verified and
          // halved until admissible, since it deviates from the blend by O(α(1-α)θ²).
          const std::span<const Vec3> ab(anchor.data() + b.begin, n);
          const Pose from = fit(ab, rest, b.weight);
          place(target, y);
          double alpha = 1.0;
          bool bound_limits = false;
          for (size_t i = 0; i < n; ++i) {
            const Index v = b.begin + static_cast<Index>(i);
            const Vec3 step = y[i] - anchor[v];
            const double len = step.norm();
            if (len > step_bound && step_bound / len < alpha) {
              alpha = step_bound / len;
              bound_limits = true;
            }
            for (const HalfSpace& h : regions.of(v)) {
              const double along = h.n.dot(step);
              if (along < 0.0 && h.d >= 0.0 && h.d / -along < alpha) {
                alpha = h.d / -along;
                bound_limits = false;
              }
            }
          }
          std::vector<Vec3> z;
          bool found = false;
          for (int k = 0; k <= kLineSearchHalvings && alpha > 0.0; ++k, alpha *= 0.5) {
            Pose p;
            p.q = from.q.slerp(alpha, target.q);
            p.c = from.c + alpha * (target.c - from.c);
            place(p, z);
            bool dummy = false;
            if (admissible(z, dummy)) {
              found = true;
              break;
            }
          }
          if (found) {
            std::copy(z.begin(), z.end(), xb.begin());
            ++st.bodies_shortened;
            if (bound_limits) ++st.bodies_bounded;
          } else {
            std::copy(ab.begin(), ab.end(), xb.begin());
            ++st.bodies_halted;
            st.vertices_halted += static_cast<Index>(n);
          }
        }
      },
      1);
  RigidEnforceStats total;
  for (const auto& s : per) {
    total.bodies_refitted += s.bodies_refitted;
    total.bodies_shortened += s.bodies_shortened;
    total.bodies_halted += s.bodies_halted;
    total.vertices_halted += s.vertices_halted;
    total.bodies_bounded += s.bodies_bounded;
  }
  return total;
}

Index RigidBodies::count_deformed(const Positions& x, double tolerance) const {
  std::atomic<Index> deformed{0};
  parallel_for(
      size(),
      [&](Index lo, Index hi) {
        for (Index bi = lo; bi < hi; ++bi) {
          const Body& b = bodies_[bi];
          const size_t n = b.rest.size();
          const std::span<const Vec3> xb(x.data() + b.begin, n);
          const Pose p = fit(xb, b.rest, b.weight);
          const Eigen::Matrix3d r = p.q.toRotationMatrix();
          Index local = 0;
          for (size_t i = 0; i < n; ++i)
            if (!((r * b.rest[i] + p.c - xb[i]).norm() <= tolerance * std::max(1.0, b.extent))) ++local;
          deformed += local;
        }
      },
      1);
  return deformed.load();
}

}  // namespace ccfr
