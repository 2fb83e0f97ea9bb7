#pragma once
/// @file formats.hpp
/// Output formats besides the OBJ frames (docs/interop.md): binary PLY per frame, VTU per frame
/// with a PVD collection (ParaView), PC2 point caches with the first frame as OBJ (Blender's Mesh
/// Cache modifier), and one time-sampled USDA file (Blender, Houdini, usdview).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ccfr/core/topology.hpp"
#include "ccfr/core/types.hpp"

namespace ccfr::io {

enum class OutputFormat { obj, ply, vtu, pc2, usda };

/// Names accepted by `output.formats` and `ccfr export --format`, in this order.
std::vector<std::string> output_format_names();
std::optional<OutputFormat> output_format_from_string(std::string_view name);
/// Parses a list of names ("obj", "vtu", ...); throws ccfr::Error naming the unknown one.
std::vector<OutputFormat> parse_output_formats(const std::vector<std::string>& names);

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
};

/// Writes `frames` (the k-th read by `positions`) into every sink, at time frame / fps; with
/// `velocities`, each frame's velocity is the backward difference to the previous one (zero for
/// the first). What `ccfr export` and the default FrameSink::resume do.
void replay_frames(const std::vector<FrameSink*>& sinks, const std::filesystem::path& dir,
                   const std::vector<int>& frames, const FramePositions& positions, double fps, bool velocities);

/// Resumes every sink of a run in `dir` after frame `last` (FrameSink::resume): the frames before
/// are read back from the OBJ frames if `formats` has obj, else from the PC2 caches if it has
/// pc2, else from the USDA samples file. `sinks` are those of `formats` but obj, in that order. Throws ccfr::Error
/// naming the file that is missing or does not fit, before any file is changed where it can tell in advance.
void resume_frame_sinks(const std::vector<FrameSink*>& sinks, const std::filesystem::path& dir, const Topology& topo,
                        const std::vector<OutputFormat>& formats, int last, const std::vector<int>& frames, double fps);

/// A sink for `format` (not obj: the OBJ frames are RunWriter's own). `every` is output.every
/// (the PC2 sample rate in frames). `formats`: all the run writes; a USDA layer with neither obj
/// nor pc2 beside it keeps its samples on disk as it goes (usd/scene.usda.samples), the only copy
/// a resume can rebuild it from (a layer is written whole at the end).
std::unique_ptr<FrameSink> make_frame_sink(OutputFormat format, const Topology& topo, double fps, int every,
                                           const std::vector<OutputFormat>& formats = {});
/// Whether a run writing `formats` keeps the USDA samples file (see make_frame_sink).
bool usda_keeps_samples(const std::vector<OutputFormat>& formats);

/// Folders a format writes into, relative to the run directory ("frames", "vtk", "blender", "usd").
std::string format_folder(OutputFormat format);

/// Reads a binary PLY frame written by the `ply` sink (float x y z), for tests and export.
Positions read_ply_positions(const std::filesystem::path& path);

}  // namespace ccfr::io
