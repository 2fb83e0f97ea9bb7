#pragma once
/// @file step_bound.hpp
/// The step bound of one outer iteration (paper Alg. "simulation loop", line 16): no movable vertex
/// ends farther than r from its anchor, so primitives that this iteration's detection did not see
/// cannot be reached. One implementation, used by the substep loop and by solvers that need the
/// bounded positions before the loop applies them (toi_clamp's path ends).
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "ccfr/core/types.hpp"

namespace ccfr {

/// What the step bound did.
struct StepBoundResult {
  Index held_back = 0;         ///< movable vertices whose step exceeded r (1 + tolerance): their advance was cut
  std::optional<Index> worst;  ///< the vertex with the longest such step, if any was held back
  double worst_length = 0.0;   ///< its step length before the bound
  double intended = 0.0;       ///< sum of the movable vertices' step lengths before the bound
  double cut = 0.0;            ///< sum of what the bound cut from them (length - r where longer than r)
};

/// out_i = a_i + min(1, r / |x_i - a_i|) (x_i - a_i) for movable vertices (inv_mass > 0); scripted
/// and fixed vertices keep x_i (their motion is known, not bounded by r). `out` may be `x`.
/// Steps longer than r (1 + `tolerance`) count as held back; if `held` is not empty (one entry per
/// vertex), it is set to 1 for exactly those vertices and 0 for all others. Deterministic for any
/// thread count.
/// `reach` (#V, m, or empty): each vertex's own bound ρ_i in place of r (adaptive_vertex_reach,
/// reach_long_steps).
StepBoundResult apply_step_bound(const Positions& x, const Positions& anchor, std::span<const double> inv_mass,
                                 double r, double tolerance, Positions& out, std::span<std::uint8_t> held = {},
                                 std::span<const double> reach = {});

/// The adaptive reach of one outer iteration (contact.adaptive_reach = f > 0; docs/feasibility.md,
/// "Adaptive reach"): how far each vertex may move in it, from its intended step s_i = intended_i −
/// anchor_i (the material solve's result against the pass's anchor).
///
/// - movable vertex: ρ_i = min(r, max(f r, δ) + 2 |s_i|), the room for its own step and for what
///   the contact response adds (repulsion, friction, impulses), and at least the repulsion band δ
///   (`repulsion_range`), so that every pair within ξ + δ of an immovable side is detected; r
///   where `full` is set (a rigid body's vertex, whose pose solve bounds it by r) or where `held`
///   is set (the last pass's step bound held it back: it gets the whole r now);
/// - vertex of inverse mass 0: ρ_i = |s_i| (1 + 1e-9), a bound on its motion: a fixed vertex's
///   s is 0, a scripted one's its known step (at most r, or the substep is subdivided), and a
///   vertex fixed for this pass (time.continuation: held_back) stays at its anchor.
///
/// Detection then pairs primitives within ρ_A + ρ_B + ξ (CollisionDetector::detect) and the step
/// bound keeps each vertex within its ρ_i: a pair left out stays at least ξ apart. Deterministic.
void adaptive_vertex_reach(const Positions& intended, const Positions& anchor, std::span<const double> inv_mass,
                           std::span<const std::uint8_t> full, std::span<const std::uint8_t> held, double r,
                           double floor_fraction, double repulsion_range, std::vector<double>& reach);

/// The longest step, in units of r, that reach_long_steps() lets a vertex take in a last pass.
constexpr double kLongStepMost = 64.0;

/// contact.momentum's reach in the last pass of a substep (docs/feasibility.md, "The last pass takes
/// the rest of a step"): every movable vertex that is not in `full` (a rigid body's vertex, bounded
/// by its pose solve) and whose intended step s_i = intended_i − anchor_i is longer than r gets
/// ρ_i = max(ρ_i, min(|s_i|, kLongStepMost r) + r): the rest of its step, with r of room beyond it
/// for what the contact response adds, as the paper's r leaves a vertex at rest. A step longer than
/// kLongStepMost r (a blow-up, not a motion) is cut there and held back like any other: its reach
/// would otherwise widen the pass's detection over the whole scene. `reach` is `r` for every
/// vertex where it is empty on entry; returns whether any ρ_i grew past r (if none did, the pass
/// may run at the uniform r). Detection then pairs primitives within ρ_A + ρ_B + ξ, the argument of
/// adaptive_vertex_reach, which never uses ρ ≤ r. Deterministic.
bool reach_long_steps(const Positions& intended, const Positions& anchor, std::span<const double> inv_mass,
                      std::span<const std::uint8_t> full, double r, std::vector<double>& reach);

}  // namespace ccfr
