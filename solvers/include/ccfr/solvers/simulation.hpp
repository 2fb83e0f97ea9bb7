#pragma once
/// @file simulation.hpp
/// The substep loop of docs/architecture.md, "One substep" (paper Alg. "Our simulation loop at
/// substep n"), with the contact solver as the pluggable stage.
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "ccfr/core/error.hpp"
#include "ccfr/geometry/aabb.hpp"
#include "ccfr/solvers/contact_solver.hpp"
#include "ccfr/solvers/frame_stats.hpp"
#include "ccfr/solvers/material_system.hpp"
#include "ccfr/solvers/scene.hpp"
#include "ccfr/solvers/tethers.hpp"

namespace ccfr {

/// Why a run stopped because pairs could not be separated (contact.on_violation): the error's
/// message, and the same facts for run.json's `stop` and stats.csv (docs/output.md).
struct StopReport {
  int frame = 0, substep = 0;  ///< the frame being computed (not written) and its substep, from 1
  Index remaining = 0;         ///< pairs (and rigid-body vertices) left closer than their offset
  std::string solver;
  /// "fixed_pair": neither side can move (obstacles, pinned or scripted vertices on both sides);
  /// "region_empty": a movable vertex's region has no point (the exact projection's certificate);
  /// "iterations_ran_out": the outer iterations ended with vertices held back by the step bound;
  /// "halted": a vertex of the pairs halted (its projection failed, it stayed at its anchor);
  /// "unresolved": none of these (e.g. a deformed rigid body, or a recount after the step bound).
  std::string cause;
  int iterations = 0, iteration_bound = 0;  ///< outer iterations of the substep run / allowed
  int halvings = 0;                         ///< times the stopping substep was halved first
  Index held_back = 0;                      ///< vertices the step bound held back in the last one
  struct Vertex {
    std::string object, kind;          ///< object name and kind
    Index local = 0;                   ///< index within its object (as in the object's own mesh)
    bool fixed = false;                ///< cannot move (obstacle, pinned or scripted vertex)
    double scripted_step = 0;          ///< > 0: scripted, moving this far per substep piece
    bool halted = false;               ///< halted in this frame
    bool held_back = false;            ///< held back by the step bound in the last outer iteration
    std::optional<bool> region_empty;  ///< movable vertices with a region: certified empty or not
  };
  struct Pair {
    std::string kind;  ///< vertex-face, edge-edge, vertex-edge, vertex-vertex
    std::vector<Vertex> a, b;
    double distance = 0, offset = 0;
  };
  std::vector<Pair> pairs;               ///< the first few close pairs
  std::vector<std::string> held_by;      ///< what holds the movable vertices: objects that cannot move
  std::vector<std::string> suggestions;  ///< what a user can change
  FrameStats stats;                      ///< the failed frame up to the stop
};

/// Everything a Simulation carries from frame to frame beyond its scene (Simulation::checkpoint):
/// with it, a Simulation built from the same scene continues exactly as the one that saved it.
/// Kinematic vertices are part of `x`; their scripted motion is a function of `time`.
struct SimulationCheckpoint {
  int frame = 0;                            ///< frames done
  double time = 0.0;                        ///< simulated time
  Positions x, v, x_prev;                   ///< #V positions, velocities, positions at the last substep's start
  std::vector<double> solver_state;         ///< ContactSolver::save_state()
  bool warned_violation = false;            ///< the once-per-run warnings already given
  std::vector<std::uint8_t> warned_capped;  ///< per object (empty: none given yet)
};

/// A hook that audits positions (penetration count), e.g. the exact audit of geometry_exact.
using AuditHook = std::function<Index(const Positions& x)>;
/// Asked before every substep piece, outer iteration and material sweep: true abandons the frame.
using CancelHook = std::function<bool()>;

/// Thrown by step_frame() when the CancelHook asked to stop: the state is partly advanced (no
/// frame's), so neither write it nor checkpoint it.
class FrameInterrupted : public Error {
 public:
  using Error::Error;
};

class Simulation {
 public:
  explicit Simulation(Scene scene);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  /// Advances one frame (all substeps). Throws NumericalError naming the frame, vertex and stage
  /// when a position becomes non-finite; the state is then that of the last finished substep.
  FrameStats step_frame();

  const Scene& scene() const { return scene_; }
  const Topology& topology() const { return scene_.topo; }
  /// The long-range attachments contact.momentum builds for pinned cloths and strands (empty otherwise).
  const Tethers& tethers() const { return tethers_; }
  /// Current positions. The buffer stays the same for the simulation's lifetime (steps and setters
  /// write into it), so a view of it (e.g. the Python binding's NumPy array) never dangles.
  const Positions& positions() const { return scene_.state.x; }
  /// Current velocities; the same buffer for the simulation's lifetime, like positions().
  const Positions& velocities() const { return scene_.state.v; }
  /// Overwrites every vertex's position between frames (#V finite values, else ccfr::Error). The
  /// positions become x_n and the anchors of the next frame: the separation guarantee holds from
  /// them only if they keep every pair at least its offset apart (not checked here; the next
  /// frame counts what it finds in violations_remaining). Vertices driven by
  /// set_kinematic_targets hold their new position; scripted ones keep following their motion.
  void set_positions(const Positions& x);
  /// Overwrites every vertex's velocity between frames (#V finite values, else ccfr::Error).
  void set_velocities(const Positions& v);
  /// Drives kinematic vertices (pinned, or of an obstacle) from outside, e.g. a handle moved by a
  /// script: during the next step_frame() vertex `vertices[k]` moves linearly from where it is to
  /// `targets[k]`, reaching it at the end of the frame, and then holds there until the next
  /// target (its scripted motion no longer applies). The step per substep piece obeys the same
  /// bound r as scripted motion (automatic subdivision, else GuaranteeError naming
  /// time.substeps). Throws ccfr::Error for a dynamic vertex, an index out of range, a
  /// non-finite target, different lengths, or a vertex of an analytic obstacle (its SDF follows
  /// the scripted motion only).
  void set_kinematic_targets(std::span<const Index> vertices, std::span<const Vec3> targets);
  int frames_done() const { return frame_; }
  /// Set when a frame stopped because pairs could not be separated (the GuaranteeError's facts).
  const std::optional<StopReport>& stop_report() const { return stop_; }
  ContactSolver& contact_solver() { return *contact_; }
  const ContactSolver& contact_solver() const { return *contact_; }
  const MaterialSystem& materials() const { return materials_; }
  /// The state after frames_done() frames, for a checkpoint.
  SimulationCheckpoint checkpoint() const;
  /// Continues from `c`, saved by checkpoint() of a Simulation of the same scene. Throws
  /// ccfr::Error naming what does not fit (vertex or object count, non-finite values, solver state).
  void restore(const SimulationCheckpoint& c);
  /// Installs an audit run per frame or per substep according to debug.audit.
  void set_audit(AuditHook hook) { audit_ = std::move(hook); }
  /// Installs a hook that can abandon a frame in progress (FrameInterrupted), e.g. on a signal.
  void set_cancel(CancelHook hook) { cancel_ = std::move(hook); }

 private:
  /// One substep of length dt (a piece of a subdivided substep, or a whole one); `halvings`: how
  /// many times this piece's substep has been halved after a squeeze (at most kSqueezeHalvings).
  void substep(FrameStats& fs, int substep_index, double dt, int halvings = 0);
  /// Times a substep that would stop the run with pairs inside their offsets is solved again as
  /// two halves (each half could be halved again; more buys little and slows every genuine stop).
  static constexpr int kSqueezeHalvings = 1;
  int halvings_ = 0;  ///< the running substep piece's halvings (the stop report names them)
  /// Whether pairs left inside their offsets stop the run (contact.on_violation error, or auto
  /// under a solver that guarantees separation).
  bool stops_on_violation() const;
  /// How an outer iteration ended, after every solver family's common tail.
  struct OuterIterationEnd {
    Index remaining = 0;         ///< violations left at the iteration's final positions
    Index held_back = 0;         ///< vertices whose advance the solver or the step bound cut
    std::optional<Index> worst;  ///< the step bound's longest held-back step, if any
    double worst_length = 0.0;   ///< its length before the bound
    /// The pass cut at most time.advance_shortfall of the intended advance (and no rigid body was
    /// bounded): the substep may end although vertices are held back.
    bool short_enough = false;
  };
  /// The end of one outer iteration, the same for every contact solver: the analytic obstacles'
  /// push, the step bound (solvers that clamp to r; paper Alg. 1 line 16) and the recount of
  /// violations at the positions the iteration really ends with. Works on solve_ against anchor_.
  /// `held`, if not empty, receives the step bound's held-back marks (time.continuation: held_back).
  OuterIterationEnd end_outer_iteration(const SolveResult& res, double t1, StepContext& ctx,
                                        std::span<std::uint8_t> held);
  /// How a substep's outer iterations ended: the last one's end and how many ran.
  struct PassesEnd : OuterIterationEnd {
    int iterations = 0;
  };
  /// The outer iterations of one substep ending at t1, from anchor_ = the state's positions
  /// (paper Alg. 1 lines 5-17): XPBD from the prediction, detection, response, resolution and the
  /// common tail, until no vertex is held back or time.iteration_bound() passes ran.
  PassesEnd run_passes(FrameStats& fs, int substep_index, double t1, bool kin_moves, StepContext& ctx);
  /// Sizes (time.continuation: held_back) or clears the per-vertex marks of the passes; true when
  /// passes after the first may move only the marked vertices.
  bool reset_continuation_marks();
  /// material_solved_ = the material sweeps from the prediction with fresh multipliers (first pass only).
  void solve_materials(FrameStats& fs, int substep_index, const StepContext& ctx);
  /// Carries isolated bodies along their rigid motion (carry_isolated_objects); returns the
  /// vertices carried only part of their way (at most r).
  Index carry_before_detection(FrameStats& fs);
  /// solve_ = the material solve, fixed and capped vertices kept at their anchors, then the
  /// contact solver's response.
  void start_from_materials(FrameStats& fs, bool masked, Index capped, StepContext& ctx);
  /// The pass's common tail (end_outer_iteration) into `end`, capped bodies counted as held back;
  /// returns whether the next pass moves only the marked vertices.
  bool finish_pass(const SolveResult& res, double t1, bool local, bool masked, Index capped, StepContext& ctx,
                   OuterIterationEnd& end);
  /// Pieces the next substep of length dt must be split into so that scripted vertices move at
  /// most r per piece and the intended advance fits in the outer iterations' step bounds.
  int subdivision(double dt);
  /// Applies contact.on_violation to a substep that ended with `remaining` violations.
  void check_violations(Index remaining, int substep_index, int iterations, Index held_back, const FrameStats& fs);
  /// The facts of a stop for `remaining` violations (StopReport), with its message.
  StopReport diagnose_stop(Index remaining, int substep_index, int iterations, Index held_back,
                           const FrameStats& fs) const;
  /// A vertex of a reported pair as the stop describes it; `halted` from vertex_diagnostics().
  StopReport::Vertex stop_vertex(Index v, std::span<const std::uint8_t> halted) const;
  /// Applies contact.on_violation to a failed in-simulation audit.
  void check_audit(Index penetrations);
  /// Adds the substep's lag behind the material step (FrameStats::lag_mean, lag_max).
  void record_lag(FrameStats& fs) const;
  /// Warns (once per object) when the step bound held vertices back at the end of a substep.
  void report_capped_speed(Index vertex, double advance, double dt);
  /// Writes each moving kinematic vertex's target at time t into `target` and its step into
  /// kinematic_step_; returns the largest step.
  double kinematic_targets(double t, Positions& target);
  /// The stop message for a scripted step longer than r after subdivision: names the solver when
  /// it, not the script, made the step long (the vertices lag their script).
  std::string kinematic_overrun(double kin_step);
  void check_finite(const Positions& x, const char* stage) const;
  void collide_analytic(Positions& x, double t) const;
  /// Carries every isolated deformable body's (tet solid, cloth, shell) anchors along its best rigid
  /// motion toward the material solve before the pass detects (and, under contact.momentum, each
  /// free grain, carry_free_grains); returns the objects and grains moved. Its whole translation
  /// (its turn at most r per vertex) where its box swept along it stays more than ξ + δ from every
  /// other object's box (swept along its own carry or scripted step); else at most r per vertex
  /// where its anchor box is more than 4r + ξ + δ from every other's, so nothing within 2r of it
  /// can meet another object this pass. A rigid motion keeps every pair of the object as far apart
  /// as it was, so the new anchors are as feasible as the old ones, and the pass's regions, built
  /// there, no longer hold back a body in free flight by its own pairs.
  Index carry_isolated_objects();
  /// The grains of particle object `o` whose box swept along their whole step (longer than r) stays
  /// more than `gap` from every other grain's swept box and every other object's box in `swept`:
  /// carried that step before detection. Returns their count.
  Index carry_free_grains(size_t o, const std::vector<AABB>& swept, double gap);
  /// contact.free_islands: the groups of two or more bodies (tet solids, cloths, shells) whose anchor
  /// boxes come within 4r + ξ + δ of one another, none pinned, scripted, held or carried on its
  /// own: each is carried by its mass-weighted translation toward the material solve where its box
  /// swept along it stays more than ξ + δ from every other object's `swept` box. The pass's regions
  /// then hold only the motion relative to the group's; each carried object's `swept` box grows by
  /// where it went. Returns the objects moved.
  Index carry_free_groups(const std::vector<AABB>& box, std::vector<AABB>& swept,
                          const std::vector<std::uint8_t>& carried_object);
  /// contact.free_islands: splits the objects into the pieces islands are made of (vertex_piece_).
  void build_pieces();
  /// contact.free_islands: restarts the islands of a solve of the substep. An island is the pieces
  /// (tet solids, cloths, shells, rigid bodies with their cores, single strands, single grains) one
  /// contact of its passes joins; it is free while none of its vertices is pinned or scripted and
  /// no contact joins it to an obstacle: then no external impulse but gravity acts on it in the
  /// substep.
  void start_islands();
  /// Joins the pieces of the last detection's contacts (ContactSolver::detected_contacts()), and
  /// hands the solver the vertices of the free islands so far (StepContext::free_island), or none.
  void join_islands(StepContext& ctx);
  /// contact.free_islands: gives each free island back the linear momentum the substep's contact solve
  /// took from it (the regions' projection is not an impulse between two sides) and the angular
  /// momentum it had at the substep's start (which the material sweeps' projection of a turning
  /// shape loses too; dt the substep, s), as one translation and one turn about its centre of the whole island, each
  /// made where the island's pieces swept along it stay more than ξ + δ from every other piece (docs/feasibility.md, "A
  /// free island keeps its momentum"). Region-projection solvers only (free_islands_), no analytic obstacles. Returns
  /// the islands moved.
  Index restore_island_momentum(double dt);
  /// contact.adaptive_reach and contact.momentum's long steps: checks the setting against the solver and the kept
  /// list, marks rigid vertices.
  void init_adaptive_reach();
  /// vertex_reach_ for pass `iteration` of the substep (adaptive_vertex_reach; in the last pass under
  /// contact.momentum, reach_long_steps), handed to the solver in `ctx`; none (the uniform r) where
  /// `uniform` and no step is longer than r; 0 for the vertices a `masked` pass fixes.
  void set_vertex_reach(int iteration, bool uniform, bool masked, StepContext& ctx);

  Scene scene_;
  std::unique_ptr<ContactSolver> contact_;
  MaterialSystem materials_;
  Tethers tethers_;                        ///< contact.momentum: the pinned cloths' and strands' long-range attachments
  std::vector<Index> kinematic_;           ///< kinematic vertex ids
  std::vector<const Motion*> kin_motion_;  ///< motion of each kinematic vertex (nullptr: static)
  /// Obstacles whose analytic shape collides through its distance function (contact.analytic_obstacles).
  std::vector<Index> analytic_obstacles_;
  Positions predicted_, anchor_, solve_, kinematic_step_;
  /// The material sweeps' result from the prediction, computed once per substep: every outer
  /// iteration restarts from the same prediction with fresh multipliers, so it is the same each time.
  Positions material_solved_;
  /// time.continuation: held_back: the vertices the last pass held back (then also those of its
  /// violated pairs: the next pass's moving vertices), the vertices of the pairs its recount found
  /// violated, and the true inverse masses while a pass runs with every other vertex's set to 0.
  std::vector<std::uint8_t> held_marks_, violated_marks_, deferred_marks_;
  /// Per vertex: its object was carried only part of its rigid motion this pass (at most r).
  std::vector<std::uint8_t> carry_capped_;
  /// contact.free_islands' pieces (build_pieces): a tet solid, cloth, shell, rigid body or obstacle is
  /// one, each connected run of a strand object's segments one, each grain of a particle cloud one
  /// (a hit moves the grain, not the cloud). Per vertex its piece; per piece its object and its
  /// vertices (piece_vertex_ from piece_first_[p] to piece_first_[p + 1]).
  std::vector<Index> vertex_piece_, piece_object_, piece_first_, piece_vertex_;
  /// Per strand piece its segments (edge ids, piece_edge_ from piece_edge_first_[p]); none for others.
  std::vector<Index> piece_edge_first_, piece_edge_;
  /// contact.free_islands' islands (start_islands): per piece its parent in the union-find, and
  /// whether it is fixed (pinned, scripted, an obstacle) or joined to a fixed one; off when the
  /// solver lists no contacts or an obstacle collides through its distance function (analytic_obstacles_).
  std::vector<Index> island_parent_;
  std::vector<std::uint8_t> island_fixed_;
  bool islands_on_ = false;
  /// Per vertex: 1 where its piece's island is free after the pass's join (StepContext::free_island).
  std::vector<std::uint8_t> free_marks_;
  /// Per object: a rigid body's core (kg), the mass at its centre no vertex carries (RigidBodies);
  /// 0 for every other object. Sized on the first start_islands().
  std::vector<double> object_core_;
  /// The root of piece p's island (path halving).
  Index island_of(Index p);
  /// The free islands' pieces: those of the island rooted at r are member[first[r]] to
  /// member[first[r + 1]] (empty for a fixed island or a piece that is not a root).
  struct IslandMembers {
    std::vector<Index> first, member;
    std::span<const Index> of(Index root) const {
      return {member.data() + first[root], static_cast<size_t>(first[root + 1] - first[root])};
    }
  };
  /// Groups the pieces by free island, and sets each piece's box at the anchors.
  IslandMembers free_island_members(std::vector<AABB>& box);
  /// A free island's move: a shift, then a turn that carries no point farther than `arc` (m).
  struct IslandMove {
    Vec3 shift = Vec3::Zero();
    double arc = 0.0;
    /// The box `b` sweeps under the move.
    AABB of(const AABB& b) const;
  };
  /// Calls f(box) for each collision primitive of piece p at the anchors: a grain's point, a
  /// strand's segments, a mesh's triangles.
  template <class F>
  void each_primitive_box(Index p, F&& f) const;
  /// Whether every primitive of piece p, swept by `move`, stays more than `gap` from every one of q
  /// (their boxes, all_apart: every pair, however many).
  bool pieces_apart(Index p, Index q, const IslandMove& move, double gap);
  std::vector<AABB> clear_scratch_, clear_near_, clear_sorted_;  ///< pieces_apart's primitive boxes
  /// The pieces sorted by their boxes' lower x at the restore's start, the widest box along x, and
  /// the farthest (m) one island's moves made since may have carried a point: island_clear's window.
  struct PieceIndex {
    explicit PieceIndex(const std::vector<AABB>& box);
    std::vector<Index> order;
    std::vector<double> lo_x;
    double width = 0.0, drift = 0.0;
  };
  /// Whether island `root` (its pieces `members`, boxes `box` per piece), swept by `move`, stays
  /// more than `gap` from every piece outside it: by boxes, and where boxes meet, by primitives.
  bool island_clear(Index root, std::span<const Index> members, const IslandMove& move, const std::vector<AABB>& box,
                    const PieceIndex& index, double gap);
  /// contact.adaptive_reach (on for a solver that takes it): each pass's per-vertex reach (m), the
  /// vertices always given r (rigid bodies'), and those the last pass's step bound held back.
  bool adaptive_reach_ = false;
  bool follow_steps_ = false;  ///< contact.momentum: the last pass takes the rest of a step (reach_long_steps)
  bool free_islands_ = false;  ///< contact.free_islands under a region-projection solver: group carry and islands
  bool reach_pass_ = false;    ///< this pass bounds each vertex by vertex_reach_
  std::vector<double> vertex_reach_;
  std::vector<std::uint8_t> reach_full_, reach_held_;
  std::vector<double> inv_mass_saved_;
  bool warned_violation_ = false;
  std::vector<bool> warned_capped_;  ///< per object: the capped-speed warning was given
  AuditHook audit_;
  CancelHook cancel_;
  /// Throws FrameInterrupted when cancel_ asks to stop.
  void check_cancel(int substep) const;
  int frame_ = 0;
  std::optional<StopReport> stop_;
  // set_kinematic_targets: per slot of kinematic_, whether it is driven from outside, from where
  // (its position when the frame started) and to where; the frame's start and end time.
  std::vector<Index> kin_slot_;  ///< #V: slot in kinematic_, -1 for dynamic vertices
  std::vector<char> driven_;
  Positions driven_from_, driven_to_;
  bool drive_pending_ = false;
  double drive_t0_ = 0.0, drive_t1_ = 0.0;
};

}  // namespace ccfr
