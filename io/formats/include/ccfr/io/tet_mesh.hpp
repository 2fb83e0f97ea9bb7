#pragma once
/// @file tet_mesh.hpp
/// Tetrahedral meshes from files (docs/interop.md): TetGen `.node`/`.ele`, Gmsh `.msh` (ASCII
/// v2 and v4), and closed surfaces tetrahedralised by the `tetgen` program.
#include <filesystem>
#include <string>
#include <vector>

#include "ccfr/core/types.hpp"

namespace ccfr::io {

struct TetMesh {
  Positions v;
  std::vector<Vec4i> t;  ///< positively oriented (tets read inverted are flipped)
};

/// Mesh file extensions ccfr reads, lower case with the dot: .obj, .off, .node, .ele, .msh.
const std::vector<std::string>& mesh_extensions();

/// TetGen's pair `stem.node` + `stem.ele`; `path` is either. Indices may start at 0 or 1 (as the
/// first node's number says); 10-node tets keep their corners. Nodes no tet uses are dropped.
/// Throws ccfr::Error naming the file and line on malformed input, an index out of range or a
/// tet of zero volume.
TetMesh read_tetgen(const std::filesystem::path& path);

/// Gmsh ASCII `.msh`, format 2.x or 4.x: the 4-node (type 4) and 10-node (type 11) tetrahedra;
/// every other element is ignored, nodes no tet uses are dropped. Binary files are refused.
TetMesh read_gmsh(const std::filesystem::path& path);

/// Tetrahedralises the closed triangle surface (v, f) with the `tetgen` program (-pY, with -q
/// `quality` when > 0): the fill's boundary is the surface itself, unsplit. With -a `max_volume`
/// (> 0), or for a surface tetgen cannot fill unsplit, -p alone lets tetgen split the surface; a
/// warning then names the fill's shortest edge when it falls below a tenth of the surface's
/// (or of a regular tet's of volume max_volume). A self-intersecting surface is refused naming the
/// count of intersecting face pairs and one pair, by `face_lines` (each face's line in its file)
/// when given. Throws ccfr::Error if tetgen is missing,
/// fails (its output is quoted) or produces no tet. `what` names the surface in messages.
TetMesh tetrahedralize(const Positions& v, const std::vector<Vec3i>& f, double quality, double max_volume,
                       const std::string& what, const std::vector<int>* face_lines = nullptr);

}  // namespace ccfr::io
