#pragma once
/// @file run_info.hpp
/// What tools need to know about a run directory, read back from its run.json.
#include <filesystem>
#include <string>
#include <vector>

namespace ccfr::io {

struct RunInfo {
  std::filesystem::path dir;
  std::string scene;             ///< scene name
  std::string solver;            ///< contact.solver
  double radius = 0.0;           ///< r
  double offset = 0.0;           ///< ξ
  double repulsion_range = 0.0;  ///< δ
  double fps = 0.0;
  bool has_run_json = false;
  std::string status;        ///< `status` of run.json ("completed", "running", "failed: ...", ...); empty if absent
  long frames_written = -1;  ///< `frames_written` of run.json; -1 if absent
  std::vector<std::filesystem::path> frames;  ///< frames/frame_*.obj present on disk, in order
  std::vector<std::string> obstacles;         ///< names of the objects of kind obstacle (config.objects)
  /// config.output.every: the run writes frames 0, every, 2 every, ... and its last (1 if absent).
  long output_every = 1;
  /// config.objects: what the audit needs to know of each object that is not moved by the contact
  /// solver as a deformable: a rigid body or an obstacle moved rigidly (static, `motion`,
  /// `keyframes`; not `animation`), and whether it is scripted (an obstacle, or a rigid body
  /// driven by its pins) so that no solver can move it.
  struct RigidObject {
    std::string name;
    bool rigid = false;     ///< its shape must stay a rigid transform of frame 0
    bool scripted = false;  ///< moved by the scene, not by the solver
  };
  std::vector<RigidObject> objects;  ///< the objects of config.objects that are rigid or scripted
};

/// Reads DIR/run.json and lists DIR/frames/frame_*.obj. Throws ccfr::Error if DIR or run.json
/// is missing or malformed. A missing run.json is accepted when `require_run_json` is false
/// (then only `frames` and `dir` are filled).
RunInfo read_run_info(const std::filesystem::path& dir, bool require_run_json = true);

/// Lists DIR/frames/frame_*.obj in frame order.
std::vector<std::filesystem::path> list_frames(const std::filesystem::path& dir);

}  // namespace ccfr::io
