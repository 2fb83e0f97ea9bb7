// ccfr.Simulation: built from a Scene (with another solver and thread count when asked), stepped,
// its state read as NumPy views and set between frames.
#include "bind_simulation.hpp"

#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "arrays.hpp"
#include "bind_scene.hpp"
#include "bindings.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/core/parallel.hpp"
#include "ccfr/io/run_recorder.hpp"

namespace ccfr::python {

py::dict frame_stats_dict(const FrameStats& s) {
  py::dict d;
  for (const StatsColumn& c : kStatsColumns) {
    const py::str key(c.name.data(), c.name.size());
    if (c.python == StatsPython::none && c.is_unknown(s))
      d[key] = py::none();
    else
      c.visit(s, [&](auto v) { d[key] = v; });
  }
  return d;
}

FrameStats step_once(PySimulation& s) {
  FrameStats fs;
  {
    py::gil_scoped_release release;
    fs = s.sim->step_frame();
  }
  s.last = fs;
  return fs;
}

namespace {

/// One row per vertex of the simulation, every value finite: `what` (positions or velocities) as
/// set_positions / set_velocities take it; anything else is a ValueError naming the row.
Positions state_rows(const PySimulation& s, const py::object& h, const char* what) {
  Positions p = to_positions(h, what);
  const size_t n = static_cast<size_t>(s.sim->topology().num_vertices());
  if (p.size() != n)
    throw py::value_error(std::string(what) + ": " + std::to_string(p.size()) + " rows given, the scene has " +
                          std::to_string(n) + " vertices");
  for (size_t i = 0; i < p.size(); ++i)
    if (!p[i].allFinite()) throw py::value_error(std::string(what) + " row " + std::to_string(i) + " is not finite");
  return p;
}

// Simulation(scene, solver, threads): the process-wide thread count set, the scene loaded again
// with contact.solver=`solver` when given, and a component's refusal located as the loader does.
std::unique_ptr<PySimulation> make_simulation(const PyScene& scene, const std::optional<std::string>& solver,
                                              std::optional<int> threads) {
  auto s = std::make_unique<PySimulation>();
  s->threads = threads.value_or(0);
  if (const std::string problem = thread_count_problem(s->threads); !problem.empty())
    throw py::value_error("threads " + problem + ", got " + std::to_string(s->threads));
  set_thread_count(s->threads);
  io::LoadedScene loaded;
  if (solver) {
    std::vector<std::string> o = scene.overrides;
    o.push_back("contact.solver=" + *solver);
    loaded = load_labelled(scene.load, o, o.back(), "Simulation(solver=" + *solver + ")");
  } else {
    loaded = scene.loaded;
  }
  s->resolved_json = loaded.resolved_json;
  s->memory = loaded.memory;
  const SimulationParams params = loaded.scene.params;
  try {
    s->sim = std::make_unique<Simulation>(std::move(loaded.scene));
  } catch (const Error& e) {
    // A component's own check names file, key path and line; an override's as load_labelled does.
    try {
      io::rethrow_located(loaded, e);
    } catch (const ConfigError& c) {
      const std::string head = "command line (--set ";
      if (c.file().rfind(head, 0) == 0)
        throw ConfigError("overrides (" + c.file().substr(head.size()), c.key_path(), 0, c.detail());
      throw;
    }
  }
  if (params.debug.audit != AuditMode::off)
    s->sim->set_audit(io::make_audit_hook(s->sim->topology(), s->sim->positions(), params));
  return s;
}

// Simulation's state between frames: positions and velocities as read-only views, and setters.
void define_simulation_state(py::class_<PySimulation>& cls) {
  cls.def_property_readonly(
         "positions", [](py::object self) { return view(self.cast<PySimulation&>().sim->positions(), self); },
         "Current positions: a read-only (n, 3) float64 view of the simulation's buffer (no copy; "
         "it follows every step). Use set_positions to change them.")
      .def_property_readonly(
          "velocities", [](py::object self) { return view(self.cast<PySimulation&>().sim->velocities(), self); },
          "Current velocities: a read-only (n, 3) float64 view, like positions.")
      .def(
          "set_positions",
          [](PySimulation& s, const py::object& x) { s.sim->set_positions(state_rows(s, x, "positions")); },
          py::arg("positions"),
          "set_positions(self, /, positions)\n--\n\nOverwrites every position ((n, 3), finite) between frames.")
      .def(
          "set_velocities",
          [](PySimulation& s, const py::object& v) { s.sim->set_velocities(state_rows(s, v, "velocities")); },
          py::arg("velocities"),
          "set_velocities(self, /, velocities)\n--\n\nOverwrites every velocity ((n, 3), finite) between frames.")
      .def(
          "set_kinematic_targets",
          [](PySimulation& s, const py::object& indices, const py::object& targets) {
            py::array raw = py::array::ensure(indices);
            if (!raw || raw.ndim() != 1 || (raw.size() > 0 && raw.dtype().kind() != 'i' && raw.dtype().kind() != 'u'))
              throw py::value_error("indices must be a 1-d integer array");
            IndexArray idx(raw);
            const Positions t = to_positions(targets, "targets");
            s.sim->set_kinematic_targets(std::span<const Index>(idx.data(), static_cast<size_t>(idx.size())), t);
          },
          py::arg("indices"), py::arg("targets"),
          "set_kinematic_targets(self, /, indices, targets)\n--\n\nDrives pinned or obstacle vertices (global "
          "indices): over the next frame each moves linearly to its target "
          "and then holds there.");
}

// Simulation's read-only figures: the last stats row, frame, time, sizes, solver, kinematic vertices.
void define_simulation_properties(py::class_<PySimulation>& cls) {
  cls.def_property_readonly(
         "stats",
         [](const PySimulation& s) -> py::object {
           return s.last ? py::object(frame_stats_dict(*s.last)) : py::object(py::none());
         },
         "The last frame's stats row (the columns of stats.csv) as a dict; None before a step.")
      .def_property_readonly(
          "frame", [](const PySimulation& s) { return s.sim->frames_done(); }, "Frames done.")
      .def_property_readonly(
          "time", [](const PySimulation& s) { return s.sim->scene().state.time; }, "Simulated time in seconds.")
      .def_property_readonly(
          "num_vertices", [](const PySimulation& s) { return s.sim->topology().num_vertices(); },
          "Vertices of all objects together.")
      .def_property_readonly(
          "solver", [](const PySimulation& s) { return s.sim->scene().params.contact.solver; },
          "The contact solver (contact.solver).")
      .def_property_readonly(
          "frames", [](const PySimulation& s) { return s.sim->scene().params.time.frames; },
          "time.frames of the scene.")
      .def_property_readonly(
          "masses",
          [](const PySimulation& s) {
            const auto& m = s.sim->scene().state.mass;
            return py::array_t<double>(static_cast<py::ssize_t>(m.size()), m.data());
          },
          "Each vertex's mass in kg as the integrator weighs it (a copy, (n,)): Σ m v over an object is its "
          "momentum. Obstacles' are 0; pinned vertices keep theirs. A rigid body's vertices carry part of its "
          "mass, the rest (its core) sits at its centre of mass, which their mass-weighted centre follows.")
      .def_property_readonly(
          "kinematic_vertices",
          [](const PySimulation& s) {
            const auto& st = s.sim->scene().state;
            std::vector<Index> k;
            for (Index v = 0; v < st.size(); ++v)
              if (st.inv_mass[v] == 0.0) k.push_back(v);
            return py::array_t<Index>(static_cast<py::ssize_t>(k.size()), k.data());
          },
          "Global indices of the pinned and obstacle vertices (those set_kinematic_targets accepts).");
}

}  // namespace

void define_simulation(py::module_& m) {
  py::class_<PySimulation> cls(m, "Simulation",
                               R"(Steps a scene frame by frame.

Simulation(scene, solver=None, threads=None): `solver` overrides contact.solver through the loader
(like `ccfr run --solver`); `threads` sets the process-wide worker count (None: all cores).

>>> sim = ccfr.Simulation(ccfr.load_scene("configs/drape.yaml"), threads=2)
>>> sim.step(2)["frame"], sim.frame, sim.positions.shape
(2, 2, (2323, 3))
>>> round(sim.time, 6)
0.033333
)");
  cls.def(py::init(&make_simulation), py::arg("scene"), py::arg("solver") = py::none(), py::arg("threads") = py::none(),
          "__init__(self, /, scene, solver=None, threads=None)\n--\n\nA simulation of `scene` (see the class).")
      .def(
          "step",
          [](PySimulation& s, int frames) {
            if (frames < 1) throw py::value_error("frames must be >= 1");
            for (int f = 0; f < frames; ++f) step_once(s);
            return frame_stats_dict(*s.last);
          },
          py::arg("frames") = 1,
          "step(self, /, frames=1)\n--\n\nAdvances `frames` frames (all substeps; the GIL is released meanwhile) and "
          "returns the last frame's "
          "stats row as a dict. Raises ccfr.GuaranteeError or ccfr.NumericalError like `ccfr run` stops.");
  define_simulation_state(cls);
  define_simulation_properties(cls);
}

}  // namespace ccfr::python
