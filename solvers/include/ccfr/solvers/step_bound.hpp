#pragma once
/// @file step_bound.hpp
/// The step bound of one outer iteration (paper Alg. "simulation loop", line 16): no movable vertex
/// ends farther than r from its anchor, so primitives that this iteration's detection did not see
/// cannot be reached. One implementation, used by the substep loop and by solvers that need the
/// bounded positions before the loop applies them (toi_clamp's path ends).
#include <cstdint>
#include <optional>
#include <span>

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
StepBoundResult apply_step_bound(const Positions& x, const Positions& anchor, std::span<const double> inv_mass,
                                 double r, double tolerance, Positions& out, std::span<std::uint8_t> held = {});

}  // namespace ccfr
