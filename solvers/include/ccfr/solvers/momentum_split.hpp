#pragma once
/// @file momentum_split.hpp
/// The split of a contact's gap between its two sides by the motion the response leaves, so that
/// the dividing plane moves with the pair instead of standing still (docs/feasibility.md,
/// "Momentum through contact").
#include <cstdint>
#include <span>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/feasibility/region.hpp"

namespace ccfr {

/// Rewrites the plane offsets {d_A, d_B} of every contact whose vertices all have inverse mass > 0,
/// that is not between mesh neighbours, and whose record is the plain one (normal n, d_A + d_B = G >= 0: no scripted
/// vertex, no turned plane), by the candidates `x` against the anchors:
///
/// \f[ a_A = \max_{k \in A} -\mathbf{n}\cdot(\mathbf{x}_k - \mathbf{a}_k), \quad
///     a_B = \max_{k \in B} \mathbf{n}\cdot(\mathbf{x}_k - \mathbf{a}_k), \quad
///     d_A = \mathrm{clamp}\big(a_A + s_A (G - a_A - a_B),\ 0,\ G\big), \quad d_B = G - d_A, \f]
///
/// a_A, a_B the largest approach of a side's vertices toward the other and s_A the mass share of
/// the paper's split. Where the candidates leave room (a_A + a_B <= G) both sides' candidates lie
/// in their planes; where they overlap, the overlap E is cut by the mass shares, as an inelastic
/// contact would. d_A + d_B = G with both >= 0, exactly as the paper's split s_A G, s_B G: the
/// separating-plane argument (design clarification 4) and the anchors' feasibility stand.
///
/// A side clamped to 0 whose candidates move away (a < 0) vacates room the other side cannot use
/// in this pass: where the other side's approach exceeds G and the room vacated exceeds both
/// `min_room` (m) and a tenth of that side's cut, its vertices are marked in `deferred` (#V, or
/// empty) and the contact counted, so that the substep runs another outer iteration from the new
/// anchors instead of ending with them held at the old plane. Returns the count of contacts
/// deferred. Regions whose records are not one per contact are left as they are.
///
/// `responds` (#V, or empty: all) marks the vertices that answer in the per-vertex response (> 0);
/// a contact none of whose vertices does (two unpinned rigid bodies, each resolved in its own pose
/// solve) keeps the paper's split.
Index split_by_motion(RegionSet& regions, std::span<const ContactPair> contacts, const Positions& anchor,
                      const Positions& x, std::span<const double> inv_mass, std::span<const double> responds,
                      double min_room, std::span<std::uint8_t> deferred = {});

}  // namespace ccfr
