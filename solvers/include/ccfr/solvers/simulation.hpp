#pragma once
/// @file simulation.hpp
/// The substep loop of docs/architecture.md, "One substep" (paper Alg. "Our simulation loop at
/// substep n"), with the contact solver as the pluggable stage.
#include <functional>
#include <limits>
#include <memory>

#include "ccfr/solvers/contact_solver.hpp"
#include "ccfr/solvers/scene.hpp"
#include "ccfr/solvers/materials.hpp"
#include "ccfr/solvers/xpbd.hpp"

namespace ccfr {

/// One row of stats.csv.
struct FrameStats {
  int frame = 0;
  double sim_time = 0.0;
  double wall_s = 0.0;
  StageTimes times;
  Index candidates = 0;            ///< largest broad-phase pair count of the frame
  Index constraints = 0;           ///< largest half-space / contact-constraint count of the frame
  Index violations_detected = 0;   ///< summed over all resolution passes of the frame
  Index violations_remaining = 0;  ///< largest count left after a substep's last pass
  Index halted_vertices = 0;       ///< summed over all resolution passes (halting events)
  /// Vertices with at least one contact (half-space or contact pair), summed over all resolution
  /// passes: the paper's "collision points"; halting in percent is 100 halted / contact_vertices.
  Index contact_vertices = 0;
  double min_distance = std::numeric_limits<double>::infinity();  ///< closest pair seen by detection
  Index penetrations = -1;         ///< audit count (-1: audit off)
  Index clamped_vertices = 0;      ///< vertices held back by the step bound r (summed)
  int outer_iterations = 0;        ///< outer iterations run in the frame (summed over substeps)
  int substeps_run = 0;            ///< substeps actually run, after automatic subdivision
  /// Plesník projections replaced by the exact projection because they landed farther from the
  /// candidate than the anchor (summed over the resolution passes; 0 for other projectors).
  Index projector_fallbacks = 0;
};

/// A hook that audits positions (penetration count), e.g. the exact audit of geometry_exact.
using AuditHook = std::function<Index(const Positions& x)>;

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
  const Positions& positions() const { return scene_.state.x; }
  int frames_done() const { return frame_; }
  ContactSolver& contact_solver() { return *contact_; }
  const MaterialSystem& materials() const { return materials_; }
  /// Installs an audit run per frame or per substep according to debug.audit.
  void set_audit(AuditHook hook) { audit_ = std::move(hook); }

 private:
  /// One substep of length dt (a piece of a subdivided substep, or a whole one).
  void substep(FrameStats& fs, int substep_index, double dt);
  /// Pieces the next substep of length dt must be split into so that scripted vertices move at
  /// most r per piece and the intended advance fits in the outer iterations' step bounds.
  int subdivision(double dt);
  /// Applies contact.on_violation to a substep that ended with `remaining` violations.
  void check_violations(Index remaining, int substep_index);
  /// Applies contact.on_violation to a failed in-simulation audit.
  void check_audit(Index penetrations);
  /// Warns (once per object) when the step bound held vertices back at the end of a substep.
  void report_capped_speed(Index vertex, double advance, double dt);
  /// Writes each moving kinematic vertex's target at time t into `target` and its step into
  /// kinematic_step_; returns the largest step.
  double kinematic_targets(double t, Positions& target);
  void check_finite(const Positions& x, const char* stage) const;
  void collide_analytic(Positions& x, double t) const;

  Scene scene_;
  std::unique_ptr<ContactSolver> contact_;
  MaterialSystem materials_;
  std::vector<Index> kinematic_;          ///< kinematic vertex ids
  std::vector<const Motion*> kin_motion_;  ///< motion of each kinematic vertex (nullptr: static)
  std::vector<Index> analytic_obstacles_;  ///< objects with an analytic shape
  Positions predicted_, anchor_, solve_, kinematic_step_;
  bool warned_violation_ = false;
  std::vector<bool> warned_capped_;  ///< per object: the capped-speed warning was given
  AuditHook audit_;
  int frame_ = 0;
};

}  // namespace ccfr
