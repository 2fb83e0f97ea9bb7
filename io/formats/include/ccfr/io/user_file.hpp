#pragma once
/// @file user_file.hpp
/// Opening files a user names (scenes, meshes, run files) without trusting the path: a symlink
/// loop, a name too long or a directory without permission is a ccfr::Error naming the path; a
/// FIFO, a device (/dev/zero) or a file beyond the size bound is refused from its stat, before
/// it is opened, so nothing blocks or reads without end.
#include <cstdint>
#include <filesystem>
#include <string>

namespace ccfr::io {

/// Largest scene file read: scene files hold parameters, meshes live in their own files.
inline constexpr std::uintmax_t kMaxSceneFileBytes = std::uintmax_t{4} << 20;
/// Largest mesh file read (OBJ, OFF, TetGen, Gmsh): far beyond any mesh that fits a run's memory.
inline constexpr std::uintmax_t kMaxMeshFileBytes = std::uintmax_t{2} << 30;

/// Checks that `path` is a regular file (symlinks followed) of at most `max_bytes`, and returns
/// its size; throws Error("<what> '<path>': <why>") otherwise (`what`: "scene file", "mesh file").
std::uintmax_t check_user_file(const std::filesystem::path& path, const std::string& what, std::uintmax_t max_bytes);

/// check_user_file, then the whole file as bytes (read through a non-blocking open, so a file
/// replaced by a FIFO after the check cannot block either).
std::string read_user_file(const std::filesystem::path& path, const std::string& what, std::uintmax_t max_bytes);

/// The status of `path` without throwing: a symlink loop or an unreadable parent is an Error
/// naming `path`; a path that does not exist is file_type::not_found.
std::filesystem::file_status user_path_status(const std::filesystem::path& path, const std::string& what);

/// A copy of `text` fit to echo on a terminal: control characters (ESC, CR, ...) and bytes that
/// are not UTF-8 become \xNN, so a file's content cannot drive the terminal.
/// `keep_newlines` keeps LF and tab (a multi-line message printed whole).
std::string printable(const std::string& text, bool keep_newlines = false);

/// Why `text` cannot be a name (empty when it can): not UTF-8, or a control character (C0, DEL,
/// C1 such as U+0085 NEL, U+2028, U+2029) that would break the line it is written on.
std::string text_problem(const std::string& text);

}  // namespace ccfr::io
