// ccfr.Run: `with ccfr.Run(sim, dir) as run:` writes the run directory of `ccfr run` while the
// simulation steps (io::RunRecorder).
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bind_simulation.hpp"
#include "bindings.hpp"
#include "ccfr/io/output.hpp"
#include "ccfr/io/run_recorder.hpp"

namespace ccfr::python {

namespace {

/// `with ccfr.Run(sim, dir) as run:` writes the run directory of `ccfr run` (io::RunRecorder).
struct PyRun {
  py::object sim_owner;  // keeps the simulation alive
  PySimulation* sim = nullptr;
  std::unique_ptr<io::RunRecorder> recorder;
  bool started = false, finished = false;
};

// Run(sim, dir, force, last_frame, argv): a recorder of `sim` into `dir` whose run.json command
// line is "python3" and `argv` (default sys.argv), up to `last_frame` (default time.frames).
std::unique_ptr<PyRun> make_run(py::object sim, const fs::path& dir, bool force, std::optional<int> last_frame,
                                std::optional<std::vector<std::string>> argv) {
  auto r = std::make_unique<PyRun>();
  r->sim_owner = sim;
  r->sim = &sim.cast<PySimulation&>();
  std::vector<std::string> args =
      argv ? *argv : py::module_::import("sys").attr("argv").cast<std::vector<std::string>>();
  std::string cmd = "python3";
  for (const auto& a : args) cmd += " " + a;
  const int last = last_frame.value_or(r->sim->sim->scene().params.time.frames);
  io::RunMeta meta = io::make_run_meta(*r->sim->sim, cmd, {});
  meta.memory_estimate = r->sim->memory.total_bytes;
  meta.memory_limit = r->sim->memory.limit_bytes;
  r->recorder =
      std::make_unique<io::RunRecorder>(dir, *r->sim->sim, r->sim->resolved_json, std::move(meta), last, force);
  return r;
}

}  // namespace

void define_run(py::module_& m) {
  py::class_<PyRun>(m, "Run",
                    R"(Writes the run directory of `ccfr run` (run.json, frames/, stats.csv) while stepping.

Run(sim, dir, force=False, last_frame=None, argv=None). Frame 0 is written on entry, frame f when f
is a multiple of output.every or equals `last_frame` (default time.frames), and run.json's status
on exit ('completed', or 'failed: ...'). `force` replaces an earlier run in `dir`; `argv` is the
command line run.json records (default sys.argv).

>>> sim = ccfr.Simulation(ccfr.load_scene("configs/drape.yaml", overrides={"time.frames": 2}), threads=2)
>>> with ccfr.Run(sim, "out/drape_doc", force=True) as run:
...     for _ in range(sim.frames):
...         stats = run.step()
>>> run.frames_written, stats["frame"], ccfr.audit("out/drape_doc").verdict
(3, 2, 'pass')
)")
      .def(py::init(&make_run), py::arg("sim"), py::arg("dir"), py::arg("force") = false,
           py::arg("last_frame") = py::none(), py::arg("argv") = py::none(),
           "__init__(self, /, sim, dir, force=False, last_frame=None, argv=None)\n--\n\nA run of `sim` into "
           "`dir` (see the class).")
      .def(
          "__enter__",
          [](py::object self) {
            auto& r = self.cast<PyRun&>();
            if (r.started) throw py::value_error("a Run is entered once");
            r.started = true;
            r.recorder->start();
            return self;
          },
          "__enter__(self, /)\n--\n\nWrites run.json (status running) and frame 0.")
      .def(
          "step",
          [](PyRun& r, int frames) {
            if (!r.started || r.finished) throw py::value_error("Run.step() works inside `with ccfr.Run(...)`");
            if (frames < 1) throw py::value_error("frames must be >= 1");
            for (int f = 0; f < frames; ++f) r.recorder->record(step_once(*r.sim));
            return frame_stats_dict(*r.sim->last);
          },
          py::arg("frames") = 1,
          "step(self, /, frames=1)\n--\n\nSteps the simulation and writes what belongs to each frame; returns the last "
          "stats.")
      .def(
          "__exit__",
          [](PyRun& r, const py::object& type, const py::object& value, const py::object&) {
            if (r.finished) return false;
            r.finished = true;
            r.recorder->finish(value.is_none() ? std::string("completed")
                                               : "failed: " + py::str(value).cast<std::string>());
            return false;
          },
          "__exit__(self, type, value, traceback, /)\n--\n\nRecords run.json's status: 'completed', or 'failed: "
          "<exception>' when the block raised (which propagates).")
      .def_property_readonly(
          "dir", [](const PyRun& r) { return r.recorder->writer().dir(); },
          "Where the run is written (DIR, or DIR.ccfr-new while it replaces an earlier run).")
      .def_property_readonly(
          "frames_written", [](const PyRun& r) { return r.recorder->writer().frames_written(); },
          "Frame files written so far (frame 0 included).");
}

}  // namespace ccfr::python
