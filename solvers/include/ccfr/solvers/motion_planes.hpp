#pragma once
/// @file motion_planes.hpp
/// Region planes fitted to the motion the candidates ask for, both sound by the separating-plane
/// argument: the split of a contact's gap between its sides by the motion that leaves, so that the
/// dividing plane moves with the pair (docs/feasibility.md, "Momentum through contact"), and the
/// turn of a plane that blocks the motion toward the candidates' closest points ("Sliding planes").
#include <cstdint>
#include <span>
#include <vector>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/feasibility/region.hpp"

namespace ccfr {

/// A contact whose side split_by_motion() held at its old plane while the other side moves away.
struct HeldSplit {
  Index contact = 0;  ///< index into the contacts
  int side = 0;       ///< the side held: 0 (A) or 1 (B)
  double cut = 0.0;   ///< how far the held side's candidates reach past its plane (m)
};

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
/// in this pass: where the other side's approach exceeds G, the contact is listed in `held` (the
/// side held and its cut, how far its candidates reach past its plane), so that held_followers()
/// can decide, once the pass has moved the vertices, whether the next pass should be run for it.
/// Returns the count listed. Regions whose records are not one per contact are left as they are.
///
/// `responds` (#V, or empty: all) marks the vertices that answer in the per-vertex response (> 0);
/// a contact none of whose vertices does (two unpinned rigid bodies, each resolved in its own pose
/// solve) keeps the paper's split, unless `paired` (per contact, or empty) marks it with 1: two bodies
/// whose candidates RigidBodies::answer_pairs() moved as the pair's answer, split by their motion
/// with each side keeping at least a tenth of its mass share (a body turning about a plane held at
/// its anchor cannot keep every vertex behind it). `other_inverse_mass` (per contact, or empty): where > 0 on a
/// contact with one side answering and the other not, the other side's generalized inverse mass
/// (a rigid body's at the contact), which takes its vertices' place in s_A.
Index split_by_motion(RegionSet& regions, std::span<const ContactPair> contacts, const Positions& anchor,
                      const Positions& x, std::span<const double> inv_mass, std::span<const double> responds,
                      std::vector<HeldSplit>& held, std::span<const double> other_inverse_mass = {},
                      std::span<const std::uint8_t> paired = {});

/// Passes the push of what cannot move on through resting pairs. A vertex pressed by a fixed or
/// scripted side (a plane of such a contact with d < 0: its anchor lies past the plane) must move
/// by at least f_v, a point of the intersection of those planes (cyclic projection from 0). For
/// every contact of such a vertex whose vertices all have inverse mass > 0 (and `responds` > 0,
/// where given) and that is not between mesh neighbours, with a_A, a_B the largest push of a side's
/// vertices toward the other along the record's n and G = d_A + d_B >= 0:
///
///  - a_A + a_B <= G: d_A = a_A + s_A (G - a_A - a_B), d_B = G - d_A (each its push and a share);
///  - A pushed past the gap (a_A > G) and a_B <= a_A / 4: d_A = min(a_A (1 + η), G + ξ / 2),
///    d_B = G - d_A < 0, and B is pushed in turn by its planes of d < 0 in the next of `rounds`
///    rounds (η: 0.1 halved each round); symmetric for B;
///  - pushes from both sides alike: left as it is (a squeeze no dividing plane resolves).
///
/// d_A + d_B = G throughout, so the separating-plane argument (design clarification 4) holds while
/// both sides reach their regions. A side given d < 0 may not (its region can be empty, and the
/// projection then leaves the vertex at its anchor): the cap d_A <= G + ξ/2 keeps the pair at least
/// ξ/2 apart along n even then, so it ends inside its offset (counted, solved again or stopped)
/// but never crossed.
/// Without it a coil resting on a turning obstacle, pressed by a face toward the coil beside it
/// at the offset (G = 0, split 0 and 0), has an empty region. Returns the count of planes moved.
Index push_through(RegionSet& regions, std::span<const ContactPair> contacts, std::span<const double> inv_mass,
                   std::span<const double> responds, int rounds);

/// Of the contacts split_by_motion() listed, those whose retreating side did vacate room at `x`
/// (the positions the pass ends with, the next pass's anchors): its least retreating vertex moved
/// away from its anchor along n by more than `min_room` (m) and a tenth of the held side's cut.
/// Their held side's vertices are marked in `deferred` (#V, or empty); returns their count, so that
/// the substep runs another outer iteration from the new anchors, where the held side finds the
/// room. A side whose candidates move away but whose own planes stop it (a card of a resting stack
/// pressed toward the one below, a body against the floor) vacates nothing, and the pass is not
/// run again for it: on the 52 cards at rest every pass asked for another, up to
/// time.max_iterations (docs/feasibility.md, "Momentum through contact").
Index held_followers(std::span<const ContactPair> contacts, std::span<const HeldSplit> held, const Positions& anchor,
                     const Positions& x, double min_room, std::span<std::uint8_t> deferred = {});

/// Gives a side resolved after the others the room the others' resolved positions leave
/// (Gauss-Seidel across the two stages of a pass: the per-vertex projection, then the rigid
/// bodies' pose solves). For every contact with `later` (#V, > 0: the vertex is placed after `x`,
/// an unpinned rigid body's) on every vertex of one side L and on none of the other side S, not
/// between mesh neighbours, with G = d_L + d_S >= 0 along the record's n:
///
/// [ a_S = \max_{k \in S} \sigma_S\,\mathbf{n}\cdot(\mathbf{x}_k - \mathbf{a}_k), \qquad
///     d_L \leftarrow \max(d_L,\ G - a_S), \quad d_S \leftarrow G - d_L, ]
///
/// a_S the largest approach of S's resolved vertices toward L (σ_S = +1 on side B, -1 on A). S is
/// final at `x`, so any L within its plane ends at least ξ from S along n: G + ξ - a_S - a_L >= ξ.
/// Every vertex moves linearly from its anchor, so min_A n·p - max_B n·p (a minimum of linear
/// functions less a maximum of them) is concave in time and the pair is at least ξ apart along n
/// on the whole step, as at its ends. d_L only grows (S kept within its own plane, a_S <= d_S), so
/// L's region still holds its anchor: a body that halts stays sound. A rigid body thus follows a
/// cloth it pushes within the pass instead of a pass later; with many contacts it could not
/// follow at all, some pair being at G = 0 in every pass. Returns the count of planes raised.
Index follow_resolved_sides(RegionSet& regions, std::span<const ContactPair> contacts, const Positions& anchor,
                            const Positions& x, std::span<const double> later);

/// Marks the movable vertices a rigid body both pushes and leaves in this pass, to be carried by
/// its motion (docs/feasibility.md, "A vertex carried by a body"). `body` (#V): the unpinned rigid
/// body of each vertex, or -1; `movable` (#V): > 0 for vertices projected one by one. Over the
/// contacts (not between mesh neighbours, G = d_A + d_B >= 0) with one side wholly on one body B
/// and the other wholly movable, B's approach toward the movable side along n is
/// a_B = max over B's vertices of their candidates' (`x`) advance against the anchors. A movable
/// vertex with a contact where a_B > G (B's candidates cut the pair) and one where a_B < 0 (they
/// leave it), and with no such contact with another body, gets carrier[v] = B (else -1).
///
/// Such a vertex sits in a wedge of B's faces that moves with B: the split gives it at most G
/// toward the faces that leave, so it cannot vacate what the faces that come ask, and B, which
/// follows it (follow_resolved_sides), advances by about G a pass. Returns the count marked.
Index mark_carried(std::span<const ContactPair> contacts, const RegionSet& regions, const Positions& anchor,
                   const Positions& x, std::span<const Index> body, std::span<const double> movable,
                   std::vector<Index>& carrier);

/// Whether every vertex of `c` is on one body B (`body`) or carried by that B (`carrier`): one
/// rigid motion then moves the whole pair and keeps its distance.
bool moves_with_one_body(const ContactPair& c, std::span<const Index> body, std::span<const Index> carrier);

/// Turns every plain contact (record normal n = the contact's, d_A + d_B = G > 0, not mesh
/// neighbours, no scripted vertex moving this substep) whose candidates `x` its plane cuts or its
/// repulsion reaches (within δ = `repulsion_range` of the pair's gap) toward the pair's
/// closest-point direction at the candidates, m₁, where that leaves them less short:
///
/// \f[ G(\mathbf{m}) = \min_{k \in A} \mathbf{m}\cdot\mathbf{a}_k - \max_{k \in B} \mathbf{m}\cdot\mathbf{a}_k
///     - \xi_{pair}, \qquad d_A = s_A\,G(\mathbf{m}),\ d_B = s_B\,G(\mathbf{m}) \f]
///
/// over the anchors a_k, with the record's own shares s_A = d_A / G. Any unit m with G(m) >= 0
/// separates the pair's anchors by its offset, so the separating-plane argument (design
/// clarification 4) holds for it as for the closest-point normal, which maximises G. m is tried at
/// m₁ and half-way from n, and kept where G(m) >= 0 and the candidates' summed shortfall
/// \f$ \sum_k \max(0, \max(0, \delta - d_{other}) - \mathbf{m}\cdot(\mathbf{x}_k - \mathbf{a}_k)\,\sigma_k - d_{side})
/// \f$ (σ = +1 on side A, -1 on B: the plane's cut and the repulsion's reach) shrinks. The contact then carries m and
/// G(m) + ξ as its normal and distance, so that its record, the response's repulsion and friction and a rigid body's
/// pose solve all act along m.
///
/// This lets a body slide over a tessellated surface: a floor vertex ahead of a box's edge has a
/// closest-point normal tilted against the motion, and its plane and repulsion lifted the box (or
/// held a cloth's vertex back) where the turned one, the floor's own normal, lets it pass. Returns
/// the count turned; regions whose records are not one per contact are left as they are.
Index turn_by_motion(std::span<ContactPair> contacts, RegionSet& regions, const Positions& anchor, const Positions& x,
                     std::span<const double> inv_mass, std::span<const Vec3> kinematic_step, double repulsion_range);

}  // namespace ccfr
