#pragma once
// The built-in frame writers: one file per writer under io/formats/src/frame_writers/, named by its
// YAML key, defining register_frame_writer_<key>(). CMake lists those files into
// builtin_frame_writers.inc, which frame_writers() expands on first use (a static library would
// drop self-registering objects nobody references). What they share is in formats.cpp. Private to
// io/formats/.
#include <filesystem>
#include <string>

#include "ccfr/io/formats.hpp"

namespace ccfr::io {

#define CCFR_BUILTIN_FRAME_WRITER(key) void register_frame_writer_##key(FrameWriterRegistry& registry);
#include "builtin_frame_writers.inc"
#undef CCFR_BUILTIN_FRAME_WRITER

/// "frame_00042.ext".
std::string frame_name(int frame, const char* ext);
/// Creates `d` and its parents; throws ccfr::Error naming it.
void make_dir(const std::filesystem::path& d);
/// A per-frame format on resume: every frame written before the checkpoint must be in `folder`
/// as frame_N.ext (else the finished run would have a gap); throws ccfr::Error naming the missing one.
void check_frames_before(const std::filesystem::path& folder, const char* ext, const ResumedFrames& before);
/// ... and the frames after the checkpoint there, left by the interrupted run, go.
void keep_frames_before(const std::filesystem::path& folder, const char* ext, const ResumedFrames& before);

template <class T>
void append_raw(std::string& s, const T& value) {
  s.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

}  // namespace ccfr::io
