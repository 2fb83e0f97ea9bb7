#pragma once
/// @file run_json.hpp
/// run.json (docs/output.md), both sides in one place: RunMeta is what a run states about itself
/// (RunWriter writes it, read_run_info() reads it back into RunInfo::meta), RunProgress what the
/// writer updates as the run goes. format_run_json() writes the file's text, parse_run_json()
/// reads it; both with nlohmann-json, and parse(format(m, p, c)) gives back m and p.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ccfr/collision/collision_detector.hpp"
#include "ccfr/core/contact_model.hpp"
#include "ccfr/io/formats.hpp"

namespace ccfr::io {

struct RunMeta {
  std::string scene, solver, broad_phase;
  /// r, ξ, δ (run.json `radius`, `offset`, `repulsion_range`) and friction (written inside the
  /// resolved scene, `config.contact.friction`, and read back from there).
  ContactModel contact;
  double fps = 0;
  int threads = 0;
  std::string command_line;       ///< the command as typed (arguments shell-quoted where needed)
  std::vector<std::string> argv;  ///< every argument, exactly; empty: not recorded
  /// What the initial configuration did to contact (clarification 5), when the solver detects.
  std::optional<InitialProximity> initial_proximity;
  /// output.formats (docs/interop.md): keys of frame_writers(); obj writes frames/frame_NNNNN.obj.
  /// Like `every` and `frames`, written inside `config.output` and read back from there.
  std::vector<std::string> formats{"obj"};
  int every = 1;       ///< output.every (the PC2 sample rate; the frames written are 0, every, 2 every, ...)
  bool frames = true;  ///< output.frames: false writes no frame in any format
  /// scene_fingerprint() of the run's initial scene, written to run.json so that a resume can tell
  /// a checkpoint of this run from one copied from another (0: not recorded).
  std::uint64_t scene_fingerprint = 0;
  /// The loader's memory estimate and the limit the run is held to (bytes; 0: not recorded).
  /// run.json's `memory` adds this process's peak resident memory so far (RunProgress).
  double memory_estimate = 0, memory_limit = 0;

  bool operator==(const RunMeta&) const = default;
};

/// The keys of run.json that change while the run goes.
struct RunProgress {
  std::string start_time;
  std::optional<std::string> end_time;  ///< null until the run finishes
  std::string status;                   ///< "running", "completed", "failed: ..."; empty: absent (read side)
  long frames_written = -1;             ///< -1: absent (read side)
  std::string resumed_json;             ///< `resumed` as compact JSON (an array); empty: absent
  std::string stop_json;                ///< `stop` as compact JSON (an object); empty: absent
  long vertices = 0;
  double peak_resident_bytes = 0;  ///< memory.peak_resident_bytes (written with the memory estimate)

  bool operator==(const RunProgress&) const = default;
};

/// The text of run.json: `ccfr` (version, commit), the keys of `meta` and `progress`, then
/// `config`, the resolved scene as JSON (embedded as a string if it is not JSON). Two-space
/// indent, a final newline; invalid UTF-8 is replaced.
std::string format_run_json(const RunMeta& meta, const RunProgress& progress, const std::string& config_json);

/// What tools need to know about a run directory, read back from its run.json.
struct RunInfo {
  std::filesystem::path dir;
  bool has_run_json = false;
  RunMeta meta;                               ///< as written (command_line, argv and the memory figures where present)
  RunProgress progress;                       ///< status and frames_written as written (empty / -1 where absent)
  std::vector<std::filesystem::path> frames;  ///< frames/frame_*.obj present on disk, in order
  std::vector<std::string> obstacles;         ///< names of the objects of kind obstacle (config.objects)
  /// config.objects: what the audit needs to know of each object that is not moved by the contact
  /// solver as a deformable: a rigid body or an obstacle moved rigidly (static, `motion`,
  /// `keyframes`; not `animation`), and whether it is scripted (an obstacle, or a rigid body
  /// driven by its pins) so that no solver can move it.
  struct RigidObject {
    std::string name;
    bool rigid = false;     ///< its shape must stay a rigid transform of frame 0
    bool scripted = false;  ///< moved by the scene, not by the solver
    bool operator==(const RigidObject&) const = default;
  };
  std::vector<RigidObject> objects;  ///< the objects of config.objects that are rigid or scripted
};

/// Parses the text of a run.json (`file` names it in errors) into everything but `dir` and
/// `frames`. `radius`, `offset`, `repulsion_range` and `fps` are required; every other key is
/// optional (files of older versions lack some) and keeps its default when absent. Throws
/// ccfr::Error naming the file and the key.
RunInfo parse_run_json(std::string_view text, const std::filesystem::path& file);

/// Reads DIR/run.json and lists DIR/frames/frame_*.obj. Throws ccfr::Error if DIR or run.json
/// is missing or malformed. A missing run.json is accepted when `require_run_json` is false
/// (then only `frames` and `dir` are filled).
RunInfo read_run_info(const std::filesystem::path& dir, bool require_run_json = true);

/// Lists DIR/frames/frame_*.obj in frame order.
std::vector<std::filesystem::path> list_frames(const std::filesystem::path& dir);

}  // namespace ccfr::io
