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

/// Scripted objects (obstacles, at least one of the two moving) that touch or come within ξ of each
/// other at some time of the run,
/// sampled at up to `max_samples` evenly spaced frames (always the first and the last): no solver
/// can move them apart, so `ccfr audit` reports their pairs as a scene error. One line per pair of
/// objects, naming the first sampled frame and the faces. Empty when none do.
std::vector<std::string> scripted_contacts(const Scene& scene, int max_samples = 61);

}  // namespace ccfr::app
