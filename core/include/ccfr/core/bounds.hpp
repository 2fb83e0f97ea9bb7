#pragma once
/// @file bounds.hpp
/// ccfr's bound on coordinates.

namespace ccfr {

/// The largest |coordinate| ccfr reads, places or simulates (scene units, metres): far beyond any
/// scene, far below where float (Embree, PLY/VTU output) or squared distances lose all precision.
/// Mesh files, placed objects, simulated positions and frames read back (render, export, audit)
/// are refused beyond it.
inline constexpr double kMaxCoordinate = 1e6;

}  // namespace ccfr
