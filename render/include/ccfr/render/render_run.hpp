#pragma once
/// @file render_run.hpp
/// Rendering a run's frames: one PNG per frame with a camera fixed over the run, a contact
/// sheet, and an MP4 through ffmpeg when it is installed.
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "ccfr/core/process.hpp"
#include "ccfr/render/renderer.hpp"

namespace ccfr::render {

struct RunRenderOptions {
  RenderOptions render;
  std::optional<Camera> camera;  ///< fixed camera; otherwise fitted to the bounds of every drawn frame
  /// Objects (by `o` name) the fitted camera leaves out of its bounds, so that a small subject on
  /// a large floor fills the picture; they are still drawn. Ignored when nothing else is left.
  std::vector<std::string> frame_exclude;
  std::filesystem::path out;  ///< output folder (created)
  int every = 1;              ///< draw every k-th frame (the last frame is always drawn)
  bool sheet = false;         ///< write out/sheet.png
  int sheet_frames = 12;      ///< at most this many frames, evenly spaced, on the sheet
  int sheet_columns = 4;
  int sheet_tile_width = 400;  ///< pixels per tile (the height follows the aspect ratio)
  bool video = false;          ///< write out/video.mp4 with ffmpeg
  double fps = 30.0;           ///< frame rate of the source frames; the video plays at fps / every
};

struct RunRenderSummary {
  std::vector<std::filesystem::path> images;  ///< one PNG per drawn frame
  std::filesystem::path sheet;                ///< empty when not written
  std::filesystem::path video;                ///< empty when not written
  std::string video_note;                     ///< why there is no video, when one was asked for
  double seconds_per_frame = 0.0;             ///< rendering only (reading and writing excluded)
  View view;                                  ///< camera and radii that were used
};

/// Called after each frame: frames done, frames in total, the PNG just written.
using ProgressCallback = std::function<void(int done, int total, const std::filesystem::path& image)>;

/// Frames drawn for `every` out of `count` frames: 0, k, 2k, ... and always the last one.
std::vector<size_t> select_frames(size_t count, int every);

/// Bounds of the `v` lines of an OBJ file, read without building the frame.
/// Throws ccfr::Error if the file cannot be read.
Bounds scan_obj_bounds(const std::filesystem::path& path);
/// The same, leaving out the vertices of the objects (`o` blocks) named in `exclude`; with
/// `trim` > 0, per axis the floor(trim · n)-th smallest and largest coordinates bound the box, so
/// that a few outlying vertices do not (n: vertices counted).
Bounds scan_obj_bounds(const std::filesystem::path& path, const std::vector<std::string>& exclude, double trim = 0.0);

/// Renders `frames` (OBJ files of one run, in order) to `options.out`/frame_NNNNN.png (named
/// after each OBJ's stem). Throws ccfr::Error for unreadable frames or an unwritable folder.
RunRenderSummary render_frames(const std::vector<std::filesystem::path>& frames, const RunRenderOptions& options,
                               const ProgressCallback& progress = {});

/// Looks a program up on PATH (core/process.hpp).
using ccfr::find_program;

/// Runs a program without a shell (core/process.hpp).
using ccfr::run_process;

/// Encodes `images` (same size, in order) into an H.264 MP4 at `fps` with ffmpeg.
/// Returns false and explains why in `message` when ffmpeg is missing or fails.
bool make_video(const std::vector<std::filesystem::path>& images, double fps, const std::filesystem::path& mp4,
                std::string& message);

}  // namespace ccfr::render
