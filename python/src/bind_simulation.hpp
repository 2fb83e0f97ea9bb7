#pragma once
// A simulation as ccfr.Simulation holds it (with what run.json needs of its scene), stepped with
// the GIL released, and its stats rows as dicts.
#include <memory>
#include <optional>
#include <string>

#include "bindings.hpp"
#include "ccfr/io/scene_loader.hpp"
#include "ccfr/solvers/simulation.hpp"

namespace ccfr::python {

/// The simulation with the loaded scene it came from (its resolved configuration goes to run.json).
struct PySimulation {
  std::string resolved_json;
  io::MemoryEstimate memory;  // the estimate the scene was admitted with (run.json `memory`)
  std::unique_ptr<Simulation> sim;
  std::optional<FrameStats> last;
  int threads = 0;
};

/// One stats.csv row as a dict, key by key from kStatsColumns (in file order): ints for integer
/// columns, floats for the others, None for an unknown value where the table says so.
py::dict frame_stats_dict(const FrameStats& s);
/// Steps one frame with the GIL released; its stats become `s.last`.
FrameStats step_once(PySimulation& s);

}  // namespace ccfr::python
