#pragma once
/// @file obj.hpp
/// Wavefront OBJ frames of the output contract (`o name`, `v x y z`, `f a b c`, `l a b ...`,
/// `p a ...`, 1-based global indices) and plain OBJ mesh import.
#include <filesystem>
#include <string>
#include <vector>

#include "ccfr/core/bounds.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/core/types.hpp"

namespace ccfr::io {

// Coordinates beyond ccfr::kMaxCoordinate (core/types.hpp) are refused by every reader here.

/// One object block of a frame file. Ranges index the frame's global arrays.
struct FrameObject {
  std::string name;
  Index vertex_begin = 0, vertex_end = 0;
  Index face_begin = 0, face_end = 0;
  Index line_begin = 0, line_end = 0;
  Index point_begin = 0, point_end = 0;
  /// Source lines (1-based; 0: none) of the block's `o`/`g` statement and of its first `f`, `l`
  /// and `p` statement, for messages about the block.
  int line = 0, first_face_line = 0, first_line_line = 0, first_point_line = 0;
};

/// A frame as read back from disk.
struct Frame {
  Positions v;                            ///< #V
  std::vector<Vec3i> faces;               ///< #F, 0-based
  std::vector<std::vector<Index>> lines;  ///< polylines, 0-based
  std::vector<Index> points;              ///< free points, 0-based
  std::vector<FrameObject> objects;
  std::vector<int> face_lines;  ///< #F: source line of each (triangulated) face
  /// The scene fingerprint of the run that wrote it (its first line, `# ccfr frame
  /// scene_fingerprint=<16 hex digits>`); 0: none recorded.
  std::uint64_t scene_fingerprint = 0;
};

/// Writes one frame atomically (temporary file in the same folder, then rename).
/// A non-zero `scene_fingerprint` (the run's, run.json) is written into its first line.
void write_frame_obj(const std::filesystem::path& path, const Topology& topo, const Positions& x,
                     std::uint64_t scene_fingerprint = 0);
/// Reads a frame written by write_frame_obj (or any OBJ with v/f/l/p/o lines). `o` and `g` start
/// a block; polygons are fan-triangulated; negative indices count back from the last vertex.
/// Texture and normal data and display statements (vt, vn, vp, s, usemtl, mtllib, ...) are
/// ignored. Throws ccfr::Error naming the file and line on malformed input, non-finite
/// coordinates, and statements that carry geometry this reader would drop (free-form `curv`,
/// `surf`, ..., `call`, or any unknown statement).
Frame read_frame_obj(const std::filesystem::path& path);

/// A triangle mesh imported from an OBJ file (polygons fan-triangulated).
struct ObjMesh {
  Positions v;
  std::vector<Vec3i> f;
  std::vector<std::vector<Index>> lines;
  std::vector<int> face_lines;  ///< #F: source line of each face, for messages
  /// Source line of the first `l` and `p` statement (0: none): objects that do not use them name
  /// the line instead of dropping them.
  int first_line_line = 0, first_point_line = 0;
};
ObjMesh read_obj_mesh(const std::filesystem::path& path);
/// A triangle mesh imported from a Geomview OFF file (the format of CGAL's, Princeton's and many
/// scanned-mesh collections): the header `OFF` (or `COFF`, `NOFF`, `STOFF`, ...; extra per-vertex
/// values are ignored), the counts `#V #F #E` (on the header's line or the next), #V vertex lines
/// and #F faces `n i0 ... i(n-1) [colour]` with 0-based indices, fan-triangulated; `#` comments
/// anywhere. Throws ccfr::Error naming the file and line on malformed input, non-finite
/// coordinates, counts the file cannot hold, 4-D/n-D or binary OFF, and data after the last face.
ObjMesh read_off_mesh(const std::filesystem::path& path);

/// Writes `content` to `path` atomically and durably: a temporary file in the same folder, synced
/// (fsync), renamed over `path`, then the folder synced; after a crash or power loss `path` holds
/// the old content or the whole new one. On failure the temporary file is removed.
void write_file_atomic(const std::filesystem::path& path, const std::string& content);

}  // namespace ccfr::io
