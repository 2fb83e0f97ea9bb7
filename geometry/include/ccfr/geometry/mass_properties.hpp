#pragma once
/// @file mass_properties.hpp
/// Mass properties of the homogeneous solid bounded by a closed triangle mesh (divergence theorem),
/// and per-vertex masses that reproduce them for a body simulated through its surface vertices.
#include <span>
#include <vector>

#include "ccfr/core/types.hpp"

namespace ccfr {

/// Volume, centre and second moment of a solid of unit density.
struct SolidMassProperties {
  double volume = 0.0;    ///< |V| (m³)
  bool inverted = false;  ///< the faces are wound inward (signed volume < 0); the moments are those of the solid anyway
  Vec3 centroid = Vec3::Zero();                             ///< centre of mass (m)
  Eigen::Matrix3d second_moment = Eigen::Matrix3d::Zero();  ///< ∫ (x - c)(x - c)ᵀ dV about the centroid (m⁵)
  /// Inertia tensor about the centroid for density `rho`: ρ (tr(S) 1 - S).
  Eigen::Matrix3d inertia(double rho) const {
    return rho * (second_moment.trace() * Eigen::Matrix3d::Identity() - second_moment);
  }
};

/// Exact mass properties of the polyhedron bounded by `faces` (indices into `v`), summed over the
/// tetrahedra (o, a, b, c) of every face with a reference point o (Tonon 2004: a tet's
/// ∫ x xᵀ dV = V/20 (Σ pᵢpᵢᵀ + (Σ pᵢ)(Σ pᵢ)ᵀ)). Exact for any closed, consistently oriented surface,
/// convex or not; orientation inward is detected and compensated. Open or inconsistently wound
/// surfaces give meaningless numbers: check them first.
SolidMassProperties solid_mass_properties(std::span<const Vec3> v, std::span<const Vec3i> faces);

/// Masses that make a shape-matched rigid body move as its solid: the vertex masses plus a `core`
/// mass at the centre of mass (which carries no second moment) have the solid's total mass, centre
/// of mass and second moment, hence its inertia tensor. Surface vertices alone cannot (a solid box's
/// corners would need a third of its mass to carry its inertia), hence the core.
struct RigidVertexMasses {
  std::vector<double> vertex;  ///< #V masses (kg), all >= 0
  double core = 0.0;           ///< mass at the centre of mass not carried by any vertex (kg)
  bool exact = false;          ///< total mass, first and second moments matched (to 1e-9 relative)
  double inertia_error = 0.0;  ///< ‖I_masses - I_solid‖_F / ‖I_solid‖_F (0 when exact)
};

/// Solves, for mass = ρ V, the nonnegative vertex masses m (and core) closest to area-lumped masses
/// (relative change, squared) subject to Σm + core = mass, Σ mᵢ qᵢ = 0 and Σ mᵢ qᵢqᵢᵀ = ρ S, with
/// qᵢ = vᵢ - c (an equality-constrained least-change QP, active set on the bounds). When the vertices
/// cannot carry S (e.g. every vertex on a cylinder's rim), falls back to core = 0 with the total mass
/// and the centre of mass still exact, and reports the inertia error; `exact` says which.
RigidVertexMasses rigid_vertex_masses(std::span<const Vec3> v, std::span<const Vec3i> faces, double rho,
                                      const SolidMassProperties& props);

}  // namespace ccfr
