#pragma once
/// @file rigid_bodies.hpp
/// Contact resolution for rigid bodies taken as a rigid motion. A region projection moves single
/// vertices; applied to a rigid body it crushes it (vertices pushed in by a floor, the rest left
/// where XPBD put them), and its pairs with itself are never detected, so nothing would report
/// the crushed body. Here a body's corrected positions are re-fitted by the best rigid transform,
/// re-checked against every vertex's region and step bound, and iterated; a body that still does
/// not fit moves only part of the way along the rigid interpolation from its anchor pose (a line
/// search that is exact for the half-spaces of a linear blend and verified for the rigid pose), or
/// halts as a whole at its anchor pose.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/core/state.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/core/types.hpp"
#include "ccfr/feasibility/region.hpp"
#include "ccfr/solvers/params.hpp"

namespace ccfr {

/// Counts of one RigidBodies::enforce pass.
struct RigidEnforceStats {
  Index bodies_refitted = 0;    ///< bodies whose projected positions were replaced by a rigid fit
  Index bodies_shortened = 0;   ///< bodies that moved only part of their rigid step (line search)
  Index bodies_halted = 0;      ///< bodies left at their anchor pose
  Index vertices_halted = 0;    ///< vertices of the halted bodies
  Index bodies_bounded = 0;     ///< bodies whose step was shortened by the step bound r alone
  Index vertices_violated = 0;  ///< vertices outside their region at the body's unconstrained pose
};

/// What the pose solve needs of one half-space's pair beyond the plane (see RigidContactOptions).
struct RigidPlaneContact {
  double repel = 0.0;                ///< the value its repulsion aims at
  double other_w = 0.0;              ///< Σ wₖ² m⁻¹ of the pair's other side
  Vec3 other_motion = Vec3::Zero();  ///< the other side's motion over the substep
  double other_wt = 0.0;             ///< its inverse mass against the friction's correction
  /// other_w when the other side is movable and answers the same repulsion in the per-vertex
  /// response (cloth, tets, strands); 0 for an obstacle or a rigid body.
  double responds_w = 0.0;
  /// The normal impulse (kg m) another unpinned body presses it with, from answer_pairs(): it
  /// joins the pose solve's own in bounding the friction.
  double pressed = 0.0;
};

/// How RigidBodies::answer_pairs() closes the contacts between two unpinned bodies.
struct PairResponse {
  double rest_overlap = 0.0;  ///< the first part of an overlap left to the planes as resting contact (m)
  int sweeps = 1;             ///< Gauss-Seidel sweeps at most
  /// δ (m) and α̃ = 1 / (k dt²): the pair's repulsion of its gap toward δ (0: none).
  double repulsion_range = 0.0;
  double repulsion_compliance = 0.0;
  /// Every vertex's inverse mass (1/kg): a side whose vertices all have 0 and lie on no rigid body
  /// (an obstacle, a pin) cannot move. Empty: only pinned bodies count as such sides.
  std::span<const double> inv_mass;
};

/// The contact response of the pose solve (the per-vertex response skips unpinned rigid bodies).
struct RigidContactOptions {
  /// Positions at the substep start: friction acts on a contact point's slip since then. Null:
  /// no friction.
  const Positions* x_start = nullptr;
  /// Repulsion: every half-space pushes softly while its value is below δ (XPBD compliance
  /// α̃ = 1 / (k dt²), as ContactResponse), a normal impulse that also bounds friction.
  double repulsion_range = 0.0;
  double repulsion_compliance = 0.0;
  /// Per plane of the RegionSet: the value its repulsion aims at, δ - (gap - d): the pair's gap
  /// exceeds the plane's value by the other side's share of it. Empty: δ for every plane.
  std::span<const double> repulsion_target;
  /// Per plane: Σ wₖ² m⁻¹ of the pair's other side, which takes its part of the repulsion's
  /// correction (XPBD: Δλ = -C / (w_body + w_other + α̃)). Empty: 0 (a fixed obstacle).
  std::span<const double> repulsion_other;
  /// Per plane: how far the pair's other side moved at its closest point over the substep
  /// (Σ |wₖ| (xₖ - xₖ_start) over its vertices). Friction acts on the slip relative to it: a body
  /// on a moving belt or on another moving body is carried along. Empty: the other side at rest.
  std::span<const Vec3> other_motion;
  /// Per plane: the generalized inverse mass of the other side at its closest point against
  /// tangential motion, which takes its part of the friction's correction. Empty: 0.
  std::span<const double> friction_other;
  /// Instead of the four spans above: the same per plane, asked only for the few planes a pose
  /// solve can act on (every plane of a body in a pile costs a pass over the pairs otherwise).
  /// Called concurrently for different bodies; its `repel` must not exceed repulsion_range.
  std::function<RigidPlaneContact(Index plane)> plane_contact;
  /// With plane_contact: its `repel` alone, cheaper (no inverse masses, no motion); asked first,
  /// so that only planes within reach of their own target get the whole pair data.
  std::function<double(Index plane)> plane_repel;
  /// Per body: a step bound of its own, at most `step_bound`; empty: `step_bound` for every body.
  std::span<const double> body_step_bound;
};

/// Where an unpinned rigid body is, for the generalized inverse mass of one of its points.
struct RigidFrame {
  Vec3 centre = Vec3::Zero();
  Eigen::Matrix3d inv_inertia = Eigen::Matrix3d::Zero();  ///< world inverse inertia
  double inv_mass = 0.0;                                  ///< 1 / (vertices' mass + core); 0: pinned
  /// w = 1/M + (r × n)ᵀ I⁻¹ (r × n), r = p - centre: the point's response to a unit impulse along n.
  double inverse_mass_at(const Vec3& p, const Vec3& n) const {
    if (inv_mass == 0.0) return 0.0;
    const Vec3 rn = (p - centre).cross(n);
    return inv_mass + rn.dot(inv_inertia * rn);
  }
};

/// A body's rigid motion between two placements: p ↦ to + turn (p - from), `from` and `to` its
/// centres of mass at the two and `turn` the rotation between their fits.
struct RigidMotion {
  Vec3 from = Vec3::Zero(), to = Vec3::Zero();
  Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
  Vec3 operator()(const Vec3& p) const { return to + turn * (p - from); }
};

/// The rigid objects of a scene with their rest shapes about their centres of mass.
class RigidBodies {
 public:
  RigidBodies() = default;
  /// Every object of kind `rigid` with at least one vertex. Bodies with kinematic (pinned)
  /// vertices follow their pins through shape matching and are refitted without a line search.
  /// With `params` (parallel to topo.objects), a body whose vertex masses sum to less than its
  /// solid's ρV (the loader's moment-matched masses, see rigid_vertex_masses) gets the rest as a core
  /// at its centre of mass: its fits then respond to corrections with the solid's mass and inertia.
  RigidBodies(const Topology& topo, const SimState& state, const SimulationParams* params = nullptr);

  bool empty() const { return bodies_.empty(); }
  Index size() const { return static_cast<Index>(bodies_.size()); }

  /// Makes every rigid body a rigid placement that keeps each of its vertices inside its region
  /// (anchored at `anchor`) and within `step_bound` of its anchor. `x` holds the candidate
  /// positions (#V, already projected vertex by vertex); rigid bodies' vertices are overwritten.
  /// A body whose step the bound shortened by more than `advance_tolerance` (relative) counts in
  /// bodies_bounded, so the substep keeps iterating until it arrives.
  /// `cores` (#bodies, from predicted_cores) places the cores; empty: no core.
  /// `contact` adds friction and repulsion (see RigidContactOptions).
  RigidEnforceStats enforce(Positions& x, const Positions& anchor, const RegionSet& regions, double step_bound,
                            double advance_tolerance = 0.01, std::span<const Vec3> cores = {},
                            const RigidContactOptions& contact = {}) const;

  /// Sets the inverse masses of the vertices of every unpinned body to 0: those bodies' contacts
  /// are resolved in their pose space by enforce(), not vertex by vertex.
  void mask_free(std::vector<double>& inv_mass) const;

  /// Where each body's core is before any contact acts in the substep: its centre of mass moved
  /// ballistically from `state` (x, v at the substep start) by dt under `gravity`, as the vertices are.
  std::vector<Vec3> predicted_cores(const SimState& state, double dt, const Vec3& gravity) const;

  /// Body `b`'s core (kg): the mass at its centre of mass that no vertex carries.
  double core_of(Index b) const { return bodies_[static_cast<size_t>(b)].core; }
  /// The body that vertex `v` belongs to, or -1.
  Index body_of(Index v) const;
  /// Every body's frame at positions `at` (its rigid fit there); pinned bodies get inv_mass 0.
  std::vector<RigidFrame> frames(const Positions& at) const;

  /// Every body's rigid motion from its fit at `from` to its fit at `to` (pinned bodies: identity).
  std::vector<RigidMotion> motions(const Positions& from, const Positions& to) const;

  /// Moves every unpinned body's vertices in `x` rigidly: turned by `turn[b]` (rotation vector,
  /// radians) about the centre of their fit and carried by `shift[b]` (both #bodies).
  void displace(Positions& x, std::span<const Vec3> shift, std::span<const Vec3> turn) const;

  /// Inelastic contact between two unpinned bodies on candidate positions `x` (contact.momentum;
  /// docs/feasibility.md, "Momentum between rigid bodies"): the contacts whose two sides lie on two
  /// different unpinned bodies, measured at their closest points,
  /// \f$C = \varphi + \mathbf{n}^\top\sum_k w_k (\mathbf{x}_k - \mathbf{a}_k) + \text{rest} \ge 0\f$,
  /// are closed by projected Gauss-Seidel on the bodies' poses (Müller et al. 2020, positional
  /// constraints between two bodies): \f$\Delta\lambda = -C / (w_A + w_B)\f$, w the generalized
  /// inverse mass of each body along n at the closest points' midpoint, λ ≥ 0 accumulated, +Δλ n
  /// on side A and -Δλ n on side B, both at that midpoint, so the pair's linear and angular momentum
  /// are kept. The first `rest_overlap` (m) of an overlap is resting contact, left to the planes.
  /// In the same sweeps each such pair's XPBD repulsion of its gap g toward δ,
  /// \f$\Delta\lambda_r = (\delta - g - \tilde\alpha\lambda_r) / (w_A + w_B + \tilde\alpha)\f$, λ_r ≥ 0,
  /// acts on both alike (the pose solves leave these planes' repulsion to it). A body in such a
  /// pair also takes, in the same sweeps, its contacts with sides that cannot move (a floor, a
  /// pinned body: w_B = 0) as C ≥ 0 with no resting part, so that the pair's pushes and turns meet
  /// the support it rests on or hangs from; their repulsion and friction stay its pose solve's. At most
  /// `response.sweeps` sweeps; the bodies' rotations are linearized within them. Writes each body's shift and turn
  /// (rotation vector about its fit's centre at `x`, #bodies), and per contact the impulse λ + λ_r it took into
  /// `repelled` and into `answered` 1 for every contact between two bodies it answers and 2 for every one with a side
  /// that cannot move, beyond reach or not (if given; 0 for the others), and returns the contacts that pushed. The
  /// caller moves the bodies (displace()).
  Index answer_pairs(const Positions& x, const Positions& anchor, std::span<const ContactPair> contacts,
                     const PairResponse& response, std::vector<Vec3>& shift, std::vector<Vec3>& turn,
                     std::vector<double>* repelled = nullptr, std::vector<std::uint8_t>* answered = nullptr) const;

  /// Vertices of rigid bodies farther than `tolerance` from the best rigid fit of their body:
  /// a deformed rigid body, which detection cannot see (its pairs with itself are not tested).
  Index count_deformed(const Positions& x, double tolerance) const;

 private:
  /// Whether the vertices of `c` in [lo, hi) cannot move: a pinned body's, or all of inverse mass 0
  /// on no rigid body (answer_pairs()).
  bool holds(const ContactPair& c, int lo, int hi, std::span<const double> inv_mass) const;

  struct Body {
    Index begin = 0, end = 0;
    bool pinned = false;
    std::vector<Vec3> rest;               ///< rest offsets about the weighted rest centre
    std::vector<double> weight;           ///< fitting weights (masses; kinematic vertices dominate)
    std::vector<std::uint8_t> kinematic;  ///< 1 for pinned vertices, which keep their scripted positions
    double extent = 0.0;                  ///< largest |rest offset|, the lever arm of a rotation
    double core = 0.0;                    ///< mass at the centre of mass carried by no vertex (kg)
    double mass = 0.0;                    ///< Σ weight (the vertices' mass; + core = the solid's)
    Eigen::Matrix3d inv_inertia = Eigen::Matrix3d::Zero();  ///< inverse of the rest inertia about the centre
    double mu_s = 0.0, mu_k = 0.0;                          ///< the body's static and kinetic friction
  };
  /// One contact of a body in the pose solve: a half-space of one of its vertices, with the
  /// accumulated normal and tangential multipliers (positional impulses, kg·m) of the sweeps.
  struct PoseContact {
    Index i = 0;  ///< vertex within the body
    Index q = 0;  ///< the plane in the RegionSet
    HalfSpace h;
    RigidPlaneContact pair;
    double lambda_n = 0.0;  ///< hard: C >= aim
    double lambda_r = 0.0;  ///< repulsion: C >= δ, compliant
    Vec3 lambda_t = Vec3::Zero();
  };
  /// A body's buffers, kept between passes so that a pass allocates nothing (docs/performance.md
  /// measures the page faults of per-pass buffers).
  struct Workspace {
    std::vector<Vec3> y, z;
    std::vector<PoseContact> contacts;  ///< only the planes that came within reach of acting
    std::vector<Index> live;            ///< indices into contacts, in plane order
    std::vector<Index> slot;            ///< per plane of the body: its index in contacts, or -1
  };
  class PoseSolver;  ///< one body's pose solve in enforce() (rigid_bodies.cpp)
  std::vector<Body> bodies_;
  mutable std::vector<Workspace> work_;
};

}  // namespace ccfr
