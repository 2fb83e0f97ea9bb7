#pragma once
/// @file formats.hpp
/// The frame writers of `output.formats` and `ccfr export --format` (docs/interop.md), one
/// registry (core/registry.hpp) of FrameSink factories: OBJ frames, binary PLY per frame, VTU per
/// frame with a PVD collection (ParaView), PC2 point caches with the first frame as OBJ (Blender's
/// Mesh Cache modifier), and one time-sampled USDA file (Blender, Houdini, usdview). A built-in
/// writer is one file under io/formats/src/frame_writers/, named by its key; downstream code adds
/// entries to frame_writers() (docs/extending.md).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "ccfr/core/registry.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/core/types.hpp"

namespace ccfr::io {

class FrameSink;

/// What a frame writer is built for: the run's (or export's) topology and timing.
struct FrameSinkContext {
  const Topology& topo;
  double fps = 0;
  int every = 1;                     ///< output.every (the PC2 sample rate in frames)
  std::vector<std::string> formats;  ///< every format written beside this one, in output.formats order
  /// A run that `ccfr run --resume` may continue (not `ccfr export`): a writer keeps on disk what
  /// its resume needs (the USDA layer alone keeps its samples file).
  bool resumable = true;
  std::uint64_t scene_fingerprint = 0;  ///< the run's (run.json), written into each OBJ frame; 0: none
};

/// The frame writers by key: `(const ParamValues&, const FrameSinkContext&) -> unique_ptr<FrameSink>`.
using FrameWriterRegistry = Registry<FrameSink, const FrameSinkContext&>;
/// Every frame writer: the built-ins (frame_writers/*.cpp, in the order of their file names) on
/// first use, then whatever downstream code adds.
FrameWriterRegistry& frame_writers();

/// Names accepted by `output.formats` and `ccfr export --format`: the registered writers.
std::vector<std::string> frame_writer_names();
/// Checks a list of names ("obj", "vtu", ...) against the registry, dropping repeats; throws
/// ccfr::Error naming the unknown one and the registered ones.
std::vector<std::string> parse_output_formats(const std::vector<std::string>& names);

/// Per-vertex data written next to the positions (VTU point data). An empty vector means the
/// field is not known (e.g. `ccfr export` from frames on disk knows only velocity).
struct VertexFields {
  Positions velocity;                     ///< m/s
  std::vector<std::uint8_t> halted;       ///< 1 if the vertex halted (fell back to its anchor) in this frame
  std::vector<std::int32_t> half_spaces;  ///< half-spaces of its region at the last detection
  /// Distance to the nearest primitive among the detected contacts (m); NaN if none was in range.
  std::vector<double> distance;
};

/// Positions of the `k`-th frame a run wrote (frame number `frame`), read back from its files.
using FramePositions = std::function<Positions(size_t k, int frame)>;

/// What a resumed run had written before its checkpoint (FrameSink::resume).
struct ResumedFrames {
  int last = 0;              ///< the checkpoint's frame
  std::vector<int> frames;   ///< frames written up to `last`, ascending
  FramePositions positions;  ///< reads them back; empty when no format the run writes can be read
  double fps = 0;            ///< frame k is at time frames[k] / fps (0 when fps is 0)
};

/// Writes one format of a run directory, frame by frame. Paths are relative to the directory
/// passed in each call, so that a staged run (DIR.ccfr-new) can be renamed between frames.
class FrameSink {
 public:
  virtual ~FrameSink() = default;
  /// Writes frame `frame` (simulated time `time`); every file it leaves is whole (atomic rename,
  /// or for PC2 the sample count in the header raised only after the samples are on disk).
  virtual void write(const std::filesystem::path& dir, int frame, double time, const Positions& x,
                     const VertexFields& fields) = 0;
  /// After the last frame (also of a run stopped early): files that need every frame (USDA).
  virtual void finish(const std::filesystem::path& dir) {}
  /// `ccfr run --resume` after frame `last`: brings the sink to where it was in the uninterrupted
  /// run after `frames` (the frames written up to `last`, ascending), so that the finished files
  /// are byte-identical to an uninterrupted run's. The default writes them again from `positions`
  /// as `ccfr export` does (replay_frames); sinks whose files are per frame or appendable keep
  /// those on disk instead.
  virtual void resume(const std::filesystem::path& dir, const ResumedFrames& before);

  /// True if write() reads VertexFields (halted, half_spaces, distance): the run gathers them
  /// only then, as that costs a pass over the regions per frame.
  virtual bool wants_fields() const { return false; }
  /// On resume, before any sink of the run changes a file: throws ccfr::Error naming what would
  /// leave the finished run incomplete (a per-frame file written before the checkpoint missing).
  virtual void check_resume(const std::filesystem::path& dir, const ResumedFrames& before) {}
  /// The order of resume() among a run's sinks, lowest first (then in output.formats order):
  /// sinks that only read and may refuse (usda: 0) before those that cut their files (pc2: 1),
  /// before the per-frame ones (2).
  virtual int resume_order() const { return 2; }
  /// How exactly this sink's files give back the positions of the frames written before a
  /// checkpoint: 0 not at all, 1 as float, 2 exactly. The run resumes from the best (the first of
  /// equals), read by saved_positions().
  virtual int saved_precision() const { return 0; }
  /// Reads back the frames `frames` (ascending) from this sink's files in `dir`; may read them
  /// all at once and throw ccfr::Error naming a file that is missing or does not fit.
  virtual FramePositions saved_positions(const std::filesystem::path& dir, const std::vector<int>& frames) {
    return {};
  }
};

/// Writes `frames` (the k-th read by `positions`) into every sink, at time frame / fps; with
/// `velocities`, each frame's velocity is the backward difference to the previous one (zero for
/// the first). What `ccfr export` and the default FrameSink::resume do.
void replay_frames(const std::vector<FrameSink*>& sinks, const std::filesystem::path& dir,
                   const std::vector<int>& frames, const FramePositions& positions, double fps, bool velocities);

/// Resumes every sink of a run in `dir` after frame `last` (FrameSink::resume): the frames before
/// are read back from the sink with the best saved_precision() (obj, else pc2, else the USDA
/// samples file). Throws ccfr::Error naming the file that is missing or does not fit, before any
/// file is changed where it can tell in advance (FrameSink::check_resume).
void resume_frame_sinks(const std::vector<FrameSink*>& sinks, const std::filesystem::path& dir, int last,
                        const std::vector<int>& frames, double fps);

/// The writer `format` built for `ctx` with its parameters `params` (checked, defaults filled in).
std::unique_ptr<FrameSink> make_frame_sink(const std::string& format, const FrameSinkContext& ctx,
                                           const ParamValues& params = {});

/// Reads a binary PLY frame written by the `ply` sink (float x y z), for tests and export.
Positions read_ply_positions(const std::filesystem::path& path);

}  // namespace ccfr::io
