#pragma once
// Warnings given by `ccfr run` before simulating, when a scene's r, ξ, substeps or speeds are
// outside the ranges docs/choosing-parameters.md recommends.
#include <string>
#include <vector>

#include "ccfr/solvers/scene.hpp"

namespace ccfr::app {

/// ξ above this fraction of the shortest edge of a cloth, shell or tet solid draws a warning: pairs
/// joined by a path of at most 2ξ that start closer than ξ are excluded from contact, so folds
/// tighter than that are not protected (docs/results.md: trouble at ξ/edge = 0.54 and 0.81).
constexpr double kMaxOffsetOverEdge = 0.5;

/// One line of advice per problem found: an offset large against the mesh, scripted motion or
/// an initial velocity that covers more than r per substep. Empty when the scene is in range.
std::vector<std::string> scene_advice(const Scene& scene);

}  // namespace ccfr::app
