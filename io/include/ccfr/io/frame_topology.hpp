#pragma once
/// @file frame_topology.hpp
/// A Topology rebuilt from a frame read back from disk, for tools that only see the output
/// directory (the penetration audit).
#include "ccfr/core/scene.hpp"
#include "ccfr/io/obj.hpp"

namespace ccfr::io {

/// One object per `o` block, with the frame's vertex order. Kinds, from what the block holds:
/// faces -> shell (its lines, if any, are kept as polylines), else lines -> strand, else
/// particles if it lists points (`p`), else a shell without faces (vertices that belong to no
/// primitive, e.g. tet interiors). Throws ccfr::Error if a face, line or point of a block indexes
/// a vertex outside that block.
Topology topology_from_frame(const Frame& frame);

/// True iff two frames have the same objects (names and ranges), faces, lines and points: the
/// same topology with possibly different positions.
bool same_structure(const Frame& a, const Frame& b);

}  // namespace ccfr::io
