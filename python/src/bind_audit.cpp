// The exact penetration audit of a run directory from Python (`ccfr audit`): ccfr.audit, its
// AuditResult and one FrameAudit per audited frame.
#include <optional>
#include <string>

#include "bind_errors.hpp"
#include "bindings.hpp"
#include "ccfr/io/obj.hpp"
#include "ccfr/io/run_audit.hpp"

namespace ccfr::python {

namespace {

struct PyAudit {
  io::RunAuditResult r;
  std::string verdict;
};

// ccfr.FrameAudit and ccfr.AuditResult.
void define_audit_classes(py::module_& m) {
  py::class_<io::FrameAuditRow>(m, "FrameAudit", "One audited frame.")
      .def_readonly("frame", &io::FrameAuditRow::frame, "The frame number.")
      .def_readonly("file", &io::FrameAuditRow::file, "The frame file audited.")
      .def_readonly("triangle_intersections", &io::FrameAuditRow::triangle_intersections,
                    "Pairs of triangles that intersect.")
      .def_readonly("segment_crossings", &io::FrameAuditRow::segment_crossings,
                    "Strand segments crossing each other or a triangle.")
      .def_readonly("close_pairs", &io::FrameAuditRow::close_pairs, "Pairs closer than the offset minus the tolerance.")
      .def_readonly("min_distance", &io::FrameAuditRow::min_distance,
                    "The smallest distance between non-adjacent pairs.")
      .def_readonly("examples", &io::FrameAuditRow::examples, "A few offending pairs, described.")
      .def_property_readonly("clean", &io::FrameAuditRow::clean, "No intersection, crossing or close pair.")
      .def("__repr__", [](const io::FrameAuditRow& r) {
        return "<FrameAudit " + std::to_string(r.frame) + ": " + (r.clean() ? "clean" : "violations") + ">";
      });
  py::class_<PyAudit>(m, "AuditResult", "The exact penetration audit of a run directory (`ccfr audit`).")
      .def_readonly("verdict", &PyAudit::verdict, "'pass', 'fail' or 'incomplete' (docs/audit.md).")
      .def_property_readonly(
          "clean", [](const PyAudit& a) { return a.r.clean(); }, "Every audited frame is clean.")
      .def_property_readonly(
          "offset", [](const PyAudit& a) { return a.r.offset; }, "The offset ξ audited against.")
      .def_property_readonly(
          "offset_source", [](const PyAudit& a) { return a.r.offset_source; },
          "Where ξ came from: 'run.json', or '--offset' (the offset argument).")
      .def_property_readonly(
          "status", [](const PyAudit& a) { return a.r.status; }, "run.json's status.")
      .def_property_readonly(
          "frames_checked", [](const PyAudit& a) { return a.r.frames_checked; }, "Frames audited.")
      .def_property_readonly(
          "frames_total", [](const PyAudit& a) { return a.r.frames_total; }, "Frame files in the run.")
      .def_property_readonly(
          "bad_frames", [](const PyAudit& a) { return a.r.bad_frames; }, "Frames with a violation.")
      .def_property_readonly(
          "violations", [](const PyAudit& a) { return a.r.violations; }, "Violations over all frames.")
      .def_property_readonly(
          "first_bad_frame", [](const PyAudit& a) { return a.r.first_bad_frame; }, "The first bad frame (-1: none).")
      .def_property_readonly(
          "first_example", [](const PyAudit& a) { return a.r.first_example; }, "The first violation, described.")
      .def_property_readonly(
          "min_distance", [](const PyAudit& a) { return a.r.min_distance; }, "The smallest distance of the run.")
      .def_property_readonly(
          "rows", [](const PyAudit& a) { return a.r.rows; }, "One FrameAudit per audited frame.")
      .def("__bool__", [](const PyAudit& a) { return a.verdict == "pass"; })
      .def("__repr__", [](const PyAudit& a) {
        return "<AuditResult " + a.verdict + ": " + std::to_string(a.r.frames_checked) + " frames, " +
               std::to_string(a.r.violations) + " violations>";
      });
}

}  // namespace

void define_audit(py::module_& m) {
  define_audit_classes(m);
  m.def(
      "audit",
      [](const fs::path& dir, std::optional<double> offset, double tolerance, int stride, bool partial,
         bool write_report) {
        io::RunAuditOptions o;
        o.offset = offset;
        o.tolerance = tolerance;
        o.stride = stride;
        if (const std::string problem = io::audit_options_problem(o); !problem.empty()) throw py::value_error(problem);
        PyAudit a;
        a.r = require_existing(dir, [&] {
          py::gil_scoped_release release;
          return io::audit_run(dir, o);
        });
        a.verdict = io::audit_verdict(a.r, partial);
        if (write_report) {
          const int code = io::audit_exit_code(a.r, a.verdict);
          io::write_file_atomic(
              dir / "audit.json",
              io::audit_report_json(a.r, a.verdict, code, partial && a.r.has_run_json && !a.r.completed()));
        }
        return a;
      },
      py::arg("run_dir"), py::arg("offset") = py::none(), py::arg("tolerance") = 1e-6, py::arg("stride") = 1,
      py::arg("partial") = false, py::arg("write_report") = false,
      "audit(run_dir, offset=None, tolerance=1e-06, stride=1, partial=False, write_report=False)\n--\n\n"
      "Audits a run directory frame by frame with the exact predicates (`ccfr audit`). offset: ξ (default: "
      "run.json's). write_report: also write DIR/audit.json as `ccfr audit` does.");
}

}  // namespace ccfr::python
