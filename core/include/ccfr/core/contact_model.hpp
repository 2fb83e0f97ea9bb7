#pragma once
/// @file contact_model.hpp
/// The distances and friction of the contact model (paper notation), with one owner: collision
/// detection, the contact solvers, the response, run.json and the audit all read this struct, and
/// the scene schema takes its defaults from it.

namespace ccfr {

struct ContactModel {
  double radius = 0.005;            ///< r: search radius and per-iteration step bound; pairs interact while φ < 2r
  double offset = 0.01;             ///< ξ: minimum separation (thickness)
  double repulsion_range = 0.0005;  ///< δ: repulsion acts while the gap beyond ξ is below δ; widens the boxes
  double friction_static = 0.0;     ///< μ_s
  double friction_kinetic = 0.0;    ///< μ_k

  bool operator==(const ContactModel&) const = default;
};

}  // namespace ccfr
