#pragma once
/// @file frame_topology.hpp
/// A Topology rebuilt from a frame read back from disk, for tools that only see the output
/// directory (the penetration audit).
#include <filesystem>

#include "ccfr/core/topology.hpp"
#include "ccfr/io/obj.hpp"

namespace ccfr::io {

/// One object per `o` block, with the frame's vertex order. A block holds one kind of element:
/// faces -> shell, lines -> strand, points (`p`) -> particles. Vertices of a block that no element
/// uses (tet interiors) are kept but belong to no primitive. Throws ccfr::Error, naming `source`
/// and the line, if a block mixes faces, lines and points (the audit would not check the minority
/// kind as such), if a block has vertices but no element at all, or if an element indexes a
/// vertex outside its block.
Topology topology_from_frame(const Frame& frame, const std::filesystem::path& source = {});

/// Vertices that belong to no face, segment or particle object (not audited).
Index unreferenced_vertices(const Topology& topology);

/// True iff two frames have the same objects (names and ranges), faces, lines and points: the
/// same topology with possibly different positions.
bool same_structure(const Frame& a, const Frame& b);

}  // namespace ccfr::io
