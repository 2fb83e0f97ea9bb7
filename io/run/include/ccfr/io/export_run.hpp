#pragma once
/// @file export_run.hpp
/// `ccfr export`: a run directory's OBJ frames written again in other formats (docs/interop.md).
/// Apart from formats.hpp because it reads the run's run.json (run_json.hpp, ccfr::run).
#include <filesystem>
#include <string>
#include <vector>

#include "ccfr/io/formats.hpp"

namespace ccfr::io {

/// Re-exports a run directory's OBJ frames into `formats` (keys of frame_writers(), each with its
/// parameters' defaults), written into `out`, by default the run directory itself. Velocities are
/// backward differences of consecutive frames on disk. Returns the number of frames exported.
/// Holds the run folder's lock (and `out`'s; `command` is recorded for a second writer's message).
/// Throws ccfr::Error on a missing run, a gap in its frames, an unreadable frame, an `out` that is
/// another run's folder, or a format the run wrote itself asked into its own folder.
int export_run(const std::filesystem::path& run_dir, const std::vector<std::string>& formats,
               const std::filesystem::path& out = {}, const std::string& command = "ccfr export");

}  // namespace ccfr::io
