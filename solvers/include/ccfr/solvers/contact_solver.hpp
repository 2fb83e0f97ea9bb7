#pragma once
#include <array>
/// @file contact_solver.hpp
/// The pluggable part of the substep (docs/architecture.md, "One substep"): detection at the
/// anchors, contact response inside XPBD, and the resolution that keeps every vertex in its region.
/// Implementations are chosen by `contact.solver` from the registry contact_solvers(); adding one
/// is one new file plus its registration (docs/extending.md).
#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "ccfr/core/registry.hpp"
#include "ccfr/core/state.hpp"
#include "ccfr/core/timer.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/solvers/params.hpp"

namespace ccfr {

class Tethers;

class CollisionDetector;
struct ContactPair;

/// What a solver sees of the current substep.
struct StepContext {
  const Topology& topo;
  const SimulationParams& params;
  double dt = 0.0;  ///< substep length
  int frame = 0, substep = 0, iteration = 0;
  StageTimes& times;  ///< solvers add their broad / narrow / resolution seconds here
  /// Known displacement of every kinematic vertex during this outer iteration (#V, zero for
  /// dynamic vertices), or empty when nothing scripted moves. Regions built at the anchors must
  /// leave room for it: a kinematic side's motion is known, not bounded by a share (Eq. 3 with a
  /// known \f$\Delta\mathbf{x}_B\f$).
  std::span<const Vec3> kinematic_step = {};
  /// One entry per vertex, or empty: count_outside() sets the entry of every vertex of each pair
  /// it counts (and leaves the others), so time.continuation: held_back can free them for the next
  /// pass. A solver that does not set them leaves that pass a full one.
  std::span<std::uint8_t> violated = {};
  /// One entry per vertex, or empty: resolve() sets the entry of every vertex it held at a plane
  /// whose other side moves away (split_by_motion), so time.continuation: held_back frees it for
  /// the next pass.
  std::span<std::uint8_t> deferred = {};
  /// One entry per vertex (m), or empty for the uniform r: how far each vertex may move in this
  /// pass (contact.adaptive_reach, adaptive_vertex_reach; contact.momentum's last pass,
  /// reach_long_steps; both in step_bound.hpp). Set only for solvers
  /// whose takes_vertex_reach() is true; detection pairs primitives within ρ_A + ρ_B + ξ.
  std::span<const double> vertex_reach = {};
  /// This pass closes what the candidates bring inside their offsets by an inelastic contact and
  /// splits each plane by the motion (contact.momentum's response): set by contact.momentum, and
  /// by the substep for its passes after one that halted a vertex (a squeeze the paper's fixed
  /// dividing planes cannot pass on).
  bool momentum = false;
  /// Pass the pushes of fixed and scripted sides on through resting pairs (push_through), with
  /// `momentum`: the last solve of a substep that would otherwise stop the run.
  bool push_through = false;
  /// Per vertex (#V, or empty: none): 1 where its piece is in a free island after this pass's join
  /// (contact.free_islands); the region solvers split those pairs' planes by the motion.
  std::span<const std::uint8_t> free_island = {};
  /// The tethers of the pinned cloths and strands (contact.tethers), or null: the momentum
  /// response pushes no vertex past them, the other side takes the rest of the overlap.
  const Tethers* tethers = nullptr;
};

/// Counts of one detection pass, as a contact solver reports them (collision's own counters are DetectionStats).
struct DetectResult {
  Index candidates = 0;   ///< broad-phase pairs (0 when reused)
  bool reused = false;    ///< the pass evaluated the kept sub-pair list (collision.reuse_skin), no broad phase
  Index constraints = 0;  ///< half-spaces (or contact constraints) produced
  double min_distance = std::numeric_limits<double>::infinity();  ///< closest pair seen, |x_A - x_B|
};

/// Counts of one resolution pass.
struct SolveResult {
  Index violations_detected = 0;   ///< vertices outside their region before resolution
  Index violations_remaining = 0;  ///< vertices still outside after resolution
  Index halted_vertices = 0;       ///< vertices that fell back to their anchor (halting events)
  /// Vertices held back by the step bound r inside the solver (rigid bodies take the bound as a
  /// whole body), and contacts whose side was held at a plane the other side vacates
  /// (split_by_motion); the substep keeps iterating while any vertex is held back.
  Index bounded_vertices = 0;
  Index contact_vertices = 0;  ///< movable vertices with at least one contact in this pass
  /// Plesník results farther from the candidate than the anchor, replaced by the exact projection.
  Index projector_fallbacks = 0;
  /// Plesník projections that did not converge within max_iterations and took the exact
  /// projection instead of halting (ProjectorParams::exact_fallback).
  Index projector_rescues = 0;
  /// Distinct vertices halted so far in the current frame (StepContext::frame), counting this pass:
  /// non-decreasing within a frame, so the frame's value is the last pass's. -1: not tracked.
  Index halted_vertices_distinct = -1;
  /// Distinct movable vertices with a contact so far in the current frame, counting this pass
  /// (the paper's collision points of the frame). -1: not tracked.
  Index contact_vertices_distinct = -1;
};

class ContactSolver {
 public:
  virtual ~ContactSolver() = default;
  virtual std::string_view name() const = 0;
  /// Once, with the initial configuration (exclusions of pairs already close at rest).
  virtual void initialize(const Topology& topo, const SimState& state, const SimulationParams& params) {}
  /// Start of an outer iteration: detection at `anchor`, the last feasible positions (#V).
  virtual DetectResult detect(const Positions& anchor, const SimState& state, StepContext& ctx) { return {}; }
  /// Contact response (repulsion within δ) and friction applied to the candidate positions `x`.
  virtual void respond(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx) {}
  /// Brings `x` back into the feasible set anchored at `anchor`.
  virtual SolveResult resolve(Positions& x, const Positions& anchor, const SimState& state, StepContext& ctx) = 0;
  /// Whether the substep clamps every vertex to the step bound r around its anchor (CCFR family).
  virtual bool clamps_to_radius() const { return false; }
  /// Whether detect() honours StepContext::vertex_reach (its detection and regions then cover only
  /// what each vertex's own bound lets it reach); the substep then bounds each vertex by it.
  virtual bool takes_vertex_reach() const { return false; }
  /// Whether the solver promises that every pair stays at least its offset apart; a substep that
  /// ends with a violation is then an error under contact.on_violation = auto.
  virtual bool guarantees_separation() const { return false; }
  /// Violations at the positions `x` the substep really ends with, recounted after the loop's own
  /// changes (the r-clamp, the analytic-obstacle push), as the audit would count them: detected
  /// sub-pairs whose exact distance is below (1 - debug.audit_tolerance) times their offset, plus
  /// rigid-body vertices that left their body's rigid placement. Empty for a solver that detects
  /// nothing (its own resolve() count stands).
  virtual std::optional<Index> count_outside(const Positions& x, const Positions& anchor, const SimState& state,
                                             StepContext& ctx) const {
    return std::nullopt;
  }
  /// One violation of the last count_outside() that found any, for error messages (e.g. "vertex
  /// 12 of 'cloth' - face 3 of 'lid' at 0.0093, offset 0.01"); empty if none.
  virtual std::string last_violation() const { return {}; }
  /// A detected pair closer than its offset (for the error that stops a run, Simulation::stop_report).
  struct ClosePair {
    int kind = 0;  ///< 0 vertex-face, 1 edge-edge, 2 vertex-edge, 3 vertex-vertex
    std::array<Index, 4> v{-1, -1, -1, -1};
    int size = 0;    ///< vertices used in v
    int side_a = 1;  ///< v[0, side_a) is one side, v[side_a, size) the other
    double distance = 0.0, offset = 0.0;
  };
  /// Up to `max` of the last detection's pairs closer than (1 - debug.audit_tolerance) times their
  /// offset at `x`, lowest pair index first (independent of the thread count). Empty for a solver
  /// without a pair list. Only called when a run stops: a plain scan.
  virtual std::vector<ClosePair> close_pairs(const Positions& x, double keep, size_t max) const { return {}; }
  /// Whether vertex v's region of the last detection is empty, certified: false when the anchor
  /// satisfies it (the anchor is a feasible point), true when the exact projection from the anchor
  /// reports it infeasible. nullopt for a solver without regions or a vertex without half-spaces.
  virtual std::optional<bool> region_empty(Index v, const Positions& anchor) const { return std::nullopt; }
  /// Per-vertex diagnostics for the VTU point data (docs/interop.md), each #V or left empty when
  /// the solver has no such notion: half-spaces of the vertex's region at the last detection,
  /// distance to the nearest primitive among the detected contacts (NaN: none in range), and
  /// whether the vertex halted (fell back to its anchor) during the current frame.
  virtual void vertex_diagnostics(std::vector<std::int32_t>& half_spaces, std::vector<double>& distance,
                                  std::vector<std::uint8_t>& halted) const {}
  /// The contacts of the last detect() (every sub-pair within reach), or null for a solver that
  /// does not list them: contact.free_islands reads the substep's free islands from them.
  virtual const std::vector<ContactPair>* detected_contacts() const { return nullptr; }
  /// The solver's collision detection, if it has one (initial-proximity counts for run.json).
  virtual const CollisionDetector* collision_detector() const { return nullptr; }
  /// State the solver carries from substep to substep beyond positions and velocities (for
  /// checkpoints): opaque numbers, restored by restore_state() into a solver initialised on the
  /// same scene. Empty for a stateless solver.
  virtual std::vector<double> save_state() const { return {}; }
  /// Restores save_state(); throws ccfr::Error when `state` cannot be this solver's on this scene.
  virtual void restore_state(std::span<const double> state);
  /// A substep's solve starts: remember the state save_state() would return (cheaply) ...
  virtual void mark_substep() {}
  /// ... and go back to it: the substep is solved again from its start, and what the abandoned
  /// solve changed (raised offsets, at positions the run never reached) must not carry over.
  virtual void rewind_substep() {}
};

/// The registry of contact solvers: ccfr, exact_projection, successive_projection, post_process,
/// toi_clamp, ogc, dat, none, then whatever downstream code adds. An entry's parameters are the keys of
/// `contact.<name>.*` in scene files; its factory receives them checked, with defaults filled in.
using ContactSolverRegistry = Registry<ContactSolver>;
ContactSolverRegistry& contact_solvers();

/// Creates the solver registered under `name` from its own parameters `params` (defaults for the
/// keys not given); throws ccfr::Error listing the valid names, or naming a bad parameter.
std::unique_ptr<ContactSolver> make_contact_solver(std::string_view name, const ParamValues& params = {});
/// Every registered contact solver, in registration order (`ccfr ablate`'s default list).
std::vector<std::string> registered_contact_solvers();

/// `none`: no deformable contact at all (obstacles still collide through their SDF when
/// contact.analytic_obstacles is on). The ablation's lower bound on cost.
class NoContactSolver final : public ContactSolver {
 public:
  std::string_view name() const override { return "none"; }
  SolveResult resolve(Positions&, const Positions&, const SimState&, StepContext&) override { return {}; }
};

}  // namespace ccfr
