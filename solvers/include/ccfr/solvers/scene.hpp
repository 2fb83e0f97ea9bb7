#pragma once
/// @file scene.hpp
/// A ready-to-simulate scene: connectivity, state and typed parameters.
#include "ccfr/core/state.hpp"
#include "ccfr/core/topology.hpp"
#include "ccfr/solvers/params.hpp"

namespace ccfr {

struct Scene {
  Topology topo;
  SimState state;
  SimulationParams params;
};

}  // namespace ccfr
