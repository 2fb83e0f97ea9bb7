#pragma once
/// @file contact_response.hpp
/// Physically active contact response inside XPBD (paper §3.3): a quadratic repulsion within δ
/// beyond the offset, attenuated by visibility weights, and position-based friction on the same
/// contacts (Macklin et al. 2014). Solved Jacobi-style with per-vertex averaging, so it runs in
/// parallel and deterministically.
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/solvers/params.hpp"

namespace ccfr {

class Tethers;

/// Cubic smoothstep \f$S(t) = 3t^2 - 2t^3\f$ on [0, 1], clamped outside.
inline double smoothstep(double t) {
  if (t <= 0.0) return 0.0;
  if (t >= 1.0) return 1.0;
  return t * t * (3.0 - 2.0 * t);
}

/// Gap of a contact beyond its offset at positions x: \f$d_c = \mathbf{n}^\top\sum_k w_k \mathbf{x}_k - \xi_c\f$
/// (ξ_c = c.offset: ξ, or the pair's reduced offset when it started closer than ξ).
double contact_gap(const ContactPair& c, const Positions& x);

/// Visibility weights \f$w_c = \prod_{j \ne c} (1 - S((d_c - d_j)/\delta_v))\f$ over the contacts j
/// that share c's query vertex (its first side-A vertex), from the gaps at detection time.
std::vector<double> visibility_weights(std::span<const ContactPair> contacts, double width);

/// Buffers of visibility_weights() kept between passes (a dense scene has millions of contacts).
struct VisibilityWorkspace {
  std::vector<Index> start, order, cursor;
  std::vector<std::uint8_t> grouped;  ///< per contact: 1 once a listed vertex's group holds it
};

/// visibility_weights() into `out`, reusing `ws`'s buffers.
void visibility_weights(std::span<const ContactPair> contacts, double width, std::vector<double>& out,
                        VisibilityWorkspace& ws);

/// The same weights, bit for bit, with the groups read from a vertex -> contact-slot incidence that
/// lists every contact (slot 4·c + k) under each of its movable vertices in contact order, as
/// CollisionDetector::plane_sources() does: vertex v's group is its slots with k = 0. Contacts whose
/// query vertex lists nothing (an immovable one) are grouped by a scan. Throws ccfr::Error if the
/// row starts do not end at the slot count. With `movable` (#V inverse masses, those apply() will
/// be given), a listed vertex's group none of whose contacts has a vertex with inverse mass > 0
/// keeps weight 1: apply() skips those contacts, and in a pile of rigid bodies (all masked) they
/// are every group.
void visibility_weights(std::span<const ContactPair> contacts, std::span<const Index> row_start,
                        std::span<const Index> slots, double width, std::vector<double>& out, VisibilityWorkspace& ws,
                        std::span<const double> movable = {});

/// The unpinned rigid bodies that answer contacts in their own pose solve (ContactResponse::separate):
/// per contact the body (-1: none), its generalized inverse mass w_o at the contact's closest point
/// along n, the arm r from the body's centre to that point and the unit direction d the body gives
/// way (+n on side A, -n on side B); per body its inverse mass and world inverse inertia, all in the
/// frame at the anchor.
struct AnsweringBodies {
  std::span<const Index> body;
  std::span<const double> inverse_mass_at;
  std::span<const Vec3> arm, away;
  std::span<const double> inv_mass;
  std::span<const Eigen::Matrix3d> inv_inertia;
};

class ContactResponse {
 public:
  /// Indexes the contacts of a new detection pass (#V vertices).
  void prepare(std::span<const ContactPair> contacts, Index num_vertices, const ContactParams& params);
  /// The same with the vertex -> contact incidence given: vertex v's corrections come from the
  /// slots `slots[row_start[v], row_start[v+1])` (4·c + k for vertex contacts[c].v[k]), in contact
  /// order, as CollisionDetector::plane_sources() lists them beside its RegionSet's row starts. Only
  /// listed vertices are moved (the detector lists the movable ones). The spans must outlive apply().
  /// `movable`: the inverse masses apply() will get (see visibility_weights); empty: any.
  void prepare(std::span<const ContactPair> contacts, std::span<const Index> row_start, std::span<const Index> slots,
               const ContactParams& params, std::span<const double> movable = {});
  /// One Jacobi pass of repulsion then friction on candidate positions `x`; `x_start` are the
  /// positions at the start of the substep (friction acts on the substep's tangential motion).
  /// `friction_of(vertex)` gives (μ_s, μ_k) for a contact by its query vertex.
  /// `other_inverse_mass` (per contact, or empty): the generalized inverse mass of a side that
  /// answers outside this response (an unpinned rigid body, whose vertices `inv_mass` masks and
  /// whose pose solve takes its share of the same Δλ): it joins Σ wₖ² mₖ⁻¹, so that the movable
  /// side moves by its share only. `record_impulses`: keep what impulse_on_movable() returns.
  void apply(Positions& x, const Positions& x_start, std::span<const double> inv_mass, const ContactParams& params,
             double dt, std::span<const double> friction_override, std::span<const double> other_inverse_mass = {},
             bool record_impulses = false);
  Index active() const { return active_; }
  /// After apply() with `other_inverse_mass` and `record_impulses`: per contact, the impulse (kg m, a positional
  /// impulse) its repulsion and friction gave the movable side where the other side answers in
  /// its own solve: Σₖ mₖ Δxₖ / nₖ over the contact's movable vertices, each of which moved by the
  /// mean of its nₖ active contacts' corrections. Zero elsewhere; empty without one.
  std::span<const Vec3> impulse_on_movable() const { return impulse_; }

  /// Inelastic contact on candidate positions `x` against the anchors the contacts were found at
  /// (docs/feasibility.md, "Momentum through contact"), in two stages of Jacobi sweeps with mass
  /// splitting (Tonge et al. 2012: a vertex in n_k overlapping contacts enters each with mass
  /// m_k / n_k and moves by the mean of their corrections, which keeps every contact balanced;
  /// plain averaging would not):
  ///
  /// 1. the first 3/4 of `sweeps`, the closest points: \f$C = \varphi + \mathbf{n}^\top\sum_k
  ///    w_k (\mathbf{x}_k - \mathbf{a}_k) \ge 0\f$, \f$\Delta\mathbf{x}_k = m_k^{-1} w_k \mathbf{n}
  ///    \Delta\lambda\f$: equal and opposite impulses on one line through the closest points, so
  ///    linear and angular momentum are both kept;
  /// 2. the rest, every vertex: the regions let each vertex of a side approach the other side by
  ///    at most that side's share of φ, so the candidates fit a contact's planes iff
  ///    \f$a_A + a_B \le \varphi\f$, a_A, a_B the sides' largest approaches along ∓n. Where they
  ///    overlap by E = a_A + a_B - φ > 0, the least impulse J on the closest points' line that
  ///    closes it, \f$\Delta\mathbf{x}_k = m_k^{-1} w_k \mathbf{n} J\f$ as in 1 (linear and angular
  ///    momentum kept), where J ≤ 4 E reaches; elsewhere (an overshooting vertex weighs little at
  ///    the closest points, a side has an immovable or self-answering vertex) side A gives way by
  ///    s E and B by (1 - s) E (every vertex beyond its side's allowed approach pulled back to it
  ///    along n), s chosen by bisection so that both sides' pull-backs carry equal momentum:
  ///    linear momentum is kept, angular momentum not exactly (the pull-backs act at the vertices
  ///    that overshoot, off the closest points' line).
  ///
  /// A side with an immovable vertex does not give way. `bodies` (or null): the unpinned rigid
  /// bodies that answer in their own solve (masked in `inv_mass`, not moved here). In a sweep where
  /// a body is in n_b overlapping contacts, contact i counts it with inverse mass
  /// \f$n_b M^{-1} + \sqrt{t_i}\sum_j \sqrt{t_j}\f$, t = w_o - M⁻¹ the turn's part of w_o (split
  /// like a vertex; the sum bounds each row of its coupling between contacts), the sweep's impulses
  /// J are summed on it, and the next sweep measures each of its contacts with the body displaced
  /// by all of them, \f$\mathbf{d}\cdot(M^{-1}\mathbf{P} + I^{-1}\mathbf{L}\times\mathbf{r})\f$:
  /// n parallel contacts move it once, not n times. What it takes is minus what the other sides
  /// got, except where the other side cannot give way (pinned, or a tethered vertex pressed along
  /// its tether): the body then closes the contact alone, the pin's impulse.
  ///
  /// Mesh neighbours are skipped, and overlaps below 1e-9 of the offset (rounding). The first
  /// `rest_overlap` (m) of every overlap is resting contact, left to the planes (which stop it at a
  /// support and cut it by the mass shares between free sides, split_by_motion): a body resting on
  /// another is pressed into it by about a substep of gravity, |g| dt², and closing that here sent
  /// every sweep through the bodies stacked on it. Only an impact's overlap beyond it is closed
  /// here. Returns the most contacts that overlapped in one sweep.
  ///
  /// A sweep measures again only the contacts that overlapped and those whose upper bound of the
  /// overlap, grown by the last sweep's steps of their vertices (max(1, |w_k|) times the approach
  /// gained), leaves them overlapping: the others' overlap is at most the bound, so 0.
  ///
  /// `tethers` (or null): a tethered vertex moved past its tether is put back on it, and in later
  /// sweeps gives way with the share of the push its tethers let through,
  /// \f$|P_T \hat{\mathbf{s}}|^2\f$ of its inverse mass (Tethers::share), P_T the projection onto
  /// the tangent space of the tethers it reached: a swing along one sphere keeps most, a vertex
  /// pressed along its tether none. Throws ccfr::Error if `bodies` does not match the contacts.
  Index separate(Positions& x, const Positions& anchor, std::span<const double> inv_mass, int sweeps,
                 double rest_overlap = 0.0, const AnsweringBodies* bodies = nullptr, const Tethers* tethers = nullptr);
  /// Measures every contact in every sweep of separate() instead of those around the last
  /// sweep's steps whose bounds leave them overlapping: the brute-force reference the listing must
  /// equal (tests). The same positions, bit for bit, without bodies; with them, up to the order of
  /// the sums on a body.
  void measure_every_sweep(bool on) { measure_every_sweep_ = on; }
  /// After separate() with `bodies`: per body, the impulse (kg m, positional) the contacts gave it
  /// and its moment about the body's centre (kg m²); the body's centre moves by M⁻¹ P and it turns
  /// by I⁻¹ L. Empty without bodies.
  std::span<const Vec3> body_impulse() const { return body_push_; }
  std::span<const Vec3> body_moment() const { return body_twist_; }

 private:
  /// Keeps the contacts and computes their visibility weights (grouped through `row_start`/`slots`
  /// when given).
  void prepare_common(std::span<const ContactPair> contacts, const ContactParams& params,
                      std::span<const Index> row_start, std::span<const Index> slots,
                      std::span<const double> movable = {});
  // The phases of one sweep of separate().
  /// A contact's overlap at x under both measures, before the rounding threshold (a mesh
  /// neighbour's: -inf), and whether it has a vertex that can move.
  struct Measured {
    double barycentric = -std::numeric_limits<double>::infinity();  ///< the closest points' approach, less the room
    double vertex = -std::numeric_limits<double>::infinity();  ///< each side's largest vertex approach, less the room
    bool moves = false;
  };
  Measured measure(Index ci, const Positions& x, const Positions& anchor, std::span<const double> inv_mass,
                   double rest_overlap) const;
  /// Overlap E of contact `ci` from its measures (0: none, rounding, or a contact that cannot move).
  double overlap(const Measured& m, Index ci, bool barycentric) const;
  /// Which contacts a sweep measures: all; those around the vertices the last sweep moved
  /// (separate_moved_) that their bounds leave overlapping, and those that overlapped; those
  /// whose vertex-measure bounds leave them overlapping (the first vertex sweep). Every other
  /// contact's overlap is at most its bound, so 0. Bodies that moved list all their contacts.
  enum class Listing { every, around_moved, by_bound };
  /// Sets separate_dl_ to each listed contact's overlap E (0: none) and overlapping_ to those with
  /// E > 0; returns how many. A measured contact's bounds become its measures.
  Index mark_overlaps(const Positions& x, const Positions& anchor, std::span<const double> inv_mass, bool barycentric,
                      double rest_overlap, Listing listing);
  /// touched_: the vertices (below nv) of the overlapping contacts, ascending; separate_count_:
  /// each one's overlapping contacts (0 for an immovable one). Other vertices' counts are stale
  /// and never read: a vertex with an overlapping contact is in it.
  void count_overlaps(Index nv, std::span<const double> inv_mass);
  /// corr_: every overlapping contact's pull-back of its vertices.
  void pull_back(const Positions& x, const Positions& anchor, std::span<const double> inv_mass, Index nv,
                 bool barycentric, const AnsweringBodies* bodies);
  /// Moves each touched vertex by the mean of its overlapping contacts' pull-backs;
  /// separate_moved_ marks the vertices that moved (all of them touched).
  /// With tethers, a capped vertex's inverse mass for the later sweeps becomes its share of the
  /// push (Tethers::share) times its `uncapped` one.
  void move_by_mean(Positions& x, std::span<const double> inv_mass, const Tethers* tethers,
                    std::span<const double> uncapped);
  /// Sums each overlapping contact's impulse of the sweep on its body (body_push_, body_twist_)
  /// and sets every body contact's separate_given_ to the body's displacement there; true if a
  /// body moved.
  bool move_bodies(const AnsweringBodies& bodies);
  std::vector<double> capped_mass_;  ///< in separate() with tethers: ρ inv_mass once a vertex is capped
  std::vector<Index> body_count_;    ///< per body, in separate(): its overlapping contacts this sweep
  /// Per body, in separate(): Σ_j √t_j over its overlapping contacts, t_j = w_o,j - M⁻¹ the turn's
  /// part of w_o. Contact i enters with n_b M⁻¹ + √t_i Σ_j √t_j, at least the sum of |A_ij| over its
  /// row (|(r_i × d)ᵀ I⁻¹ (r_j × d)| <= √(t_i t_j)): a sweep's impulses then do not overshoot it.
  std::vector<double> body_split_;
  std::vector<Vec3> body_push_, body_twist_;  ///< per body, in separate(): see body_impulse()
  std::vector<double> separate_impulse_;      ///< per contact, in separate(): J of the sweep on its body
  std::vector<Index> body_contacts_;          ///< in separate(): the contacts with an answering body
  bool bodies_moved_ = false;                 ///< in separate(): a body moved in the last sweep

  std::span<const ContactPair> contacts_;
  std::vector<double> visibility_;
  VisibilityWorkspace visibility_ws_;
  std::vector<Index> vertex_row_start_, vertex_contacts_;  ///< CSR vertex -> contact slots (first prepare())
  std::span<const Index> row_start_, slots_;               ///< the CSR in use: the vectors above or the caller's
  /// apply()'s contacts in blocks of kStageBlock: block b's active ones have their 4 corrections
  /// at stage_[b][4 · corr_at_[c]], in contact order. A pile's contacts are mostly beyond δ or
  /// occluded (the 50 layers: 16 % active), so only the active ones hold slots.
  static constexpr Index kStageBlock = 2048;
  std::vector<std::vector<Vec3>> stage_;
  /// Per contact: in apply(), its first slot in its block's stage (-1: inactive); in separate(),
  /// its position in overlapping_ (read only while it overlaps).
  std::vector<Index> corr_at_;
  /// corr_at_'s and impulse_'s large buffers of a substep's first pass, kept constructed through
  /// its small held-back passes (resize_for_overwrite with a spare).
  std::vector<Index> spare_corr_at_;
  std::vector<Vec3> spare_impulse_;
  std::vector<Vec3> corr_;  ///< in separate(): 4 pull-back slots per overlapping contact, in list order
  /// After apply(): the correction of contact slot 4·c + k, or null where contact c is inactive.
  const Vec3* applied_correction(Index slot) const {
    const Index c = slot / 4, at = corr_at_[static_cast<size_t>(c)];
    return at < 0 ? nullptr : &stage_[static_cast<size_t>(c / kStageBlock)][static_cast<size_t>(at + slot % 4)];
  }
  std::vector<Vec3> impulse_;                 ///< per contact, in apply(): see impulse_on_movable()
  std::vector<int> gathered_;                 ///< per vertex, in apply(): its active contacts
  std::vector<double> separate_dl_;           ///< per contact, in separate(): Δλ of the sweep (0: inactive)
  std::vector<Index> separate_count_;         ///< per vertex, in separate(): active contacts of the sweep
  std::vector<std::uint8_t> separate_moved_;  ///< per vertex, in separate(): moved in the last sweep
  std::vector<Vec3> separate_step_;           ///< per vertex, in separate(): its step in the last sweep it moved (m)
  /// Per contact, in separate(): upper bounds on its overlap under each measure (m), exact where
  /// it was last measured, grown by its vertices' steps since.
  struct OverlapBound {
    double barycentric, vertex;
  };
  std::vector<OverlapBound> bounds_;
  bool measure_every_sweep_ = false;           ///< see measure_every_sweep()
  bool steps_pending_ = false;                 ///< in separate(): the bounds lack the last sweep's steps
  std::vector<std::uint8_t> is_body_contact_;  ///< per contact, in separate(): listed in body_contacts_
  /// touch_start_/touch_ and listed_ for separate()'s contacts, built at its first partial sweep.
  void build_touch(Index nv);
  std::vector<Index> touch_start_, touch_;  ///< in separate(): CSR vertex -> every contact touching it
  /// Per touch_ entry: g with max(0, g·s) the most a step s of the vertex grows the contact's overlap.
  std::vector<Vec3> touch_growth_;
  bool touch_built_ = false;                ///< touch_ holds this separate() call's contacts
  std::vector<Index> overlapping_;          ///< in separate(): the contacts with E > 0 this sweep
  std::vector<Index> touched_;              ///< in separate(): the overlapping contacts' vertices
  std::vector<std::uint8_t> touched_mark_;  ///< per vertex, in count_overlaps(): already in touched_
  std::vector<std::uint8_t> listed_;        ///< per contact, in mark_overlaps(): already listed
  std::vector<double> separate_given_;      ///< per contact, in separate(): its body's give along its direction (m)
  bool prepared_repulsion_ = false;         ///< the last prepare() computed weights and buffers
  Index active_ = 0;
};

}  // namespace ccfr
