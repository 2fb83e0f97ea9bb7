#pragma once
/// @file state.hpp
/// Simulation state as structure-of-arrays over the global vertex array.
#include <vector>

#include "ccfr/core/types.hpp"

namespace ccfr {

struct SimState {
  Positions x;                   ///< #V current positions
  Positions x_prev;              ///< #V positions at the start of the current step (x_n)
  Positions v;                   ///< #V velocities
  Positions rest;                ///< #V initial configuration (rest shape, kinematic reference)
  std::vector<double> mass;      ///< #V lumped masses (0 for kinematic vertices)
  std::vector<double> inv_mass;  ///< #V inverse masses; 0 for pinned and kinematic vertices
  double time = 0.0;

  Index size() const { return static_cast<Index>(x.size()); }
  void resize(Index n);
};

}  // namespace ccfr
