// The projectors from Python: ccfr.project of a candidate point into the region of half-spaces by a
// named method, its ccfr.Projection result, and projector_names.
#include <cmath>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "bindings.hpp"
#include "ccfr/core/bounds.hpp"
#include "ccfr/core/error.hpp"
#include "ccfr/feasibility/projector.hpp"

namespace ccfr::python {

void define_projection(py::module_& m) {
  py::class_<ProjectResult>(m, "Projection", "The result of ccfr.project.")
      .def_property_readonly(
          "x", [](const ProjectResult& r) { return py::array_t<double>(3, r.x.data()); }, "The projected point.")
      .def_property_readonly(
          "status", [](const ProjectResult& r) { return std::string(to_string(r.status)); },
          "'feasible', 'projected', 'halted' or 'infeasible'.")
      .def_readonly("iterations", &ProjectResult::iterations, "Iterations the method took.")
      .def_readonly("active", &ProjectResult::active, "Half-spaces violated by the candidate.")
      .def_readonly(
          "fell_back", &ProjectResult::fell_back,
          "Plesník only: its point was farther from the candidate than the anchor, so x is the exact projection.");
  m.def("projector_names", &projector_names,
        "projector_names()\n--\n\nThe projector methods: plesnik, successive_projection, exact.");
  m.def(
      "project",
      [](const py::object& anchor, const py::object& candidate, const py::object& planes, const std::string& method,
         double epsilon, int max_iterations, int sweeps) {
        const Positions a = to_positions(real_array(anchor, "anchor").reshape({1, 3}), "anchor");
        const Positions c = to_positions(real_array(candidate, "candidate").reshape({1, 3}), "candidate");
        RowArray p = real_array(planes, "planes");
        if (!p || (p.size() > 0 && (p.ndim() != 2 || p.shape(1) != 4)) || (p.size() == 0 && p.ndim() > 2))
          throw py::value_error("planes must be a (k, 4) array of rows (nx, ny, nz, d)");
        std::vector<HalfSpace> hs(static_cast<size_t>(p.size() / 4));
        const double* d = p.data();
        for (size_t k = 0; k < hs.size(); ++k)
          hs[k].n = Vec3(d[4 * k], d[4 * k + 1], d[4 * k + 2]), hs[k].d = d[4 * k + 3];
        // Bounded as scene coordinates are (kMaxCoordinate), normals unit within 1e-6.
        const auto bounded = [](const Vec3& x, const char* name) {
          if (!x.allFinite() || x.cwiseAbs().maxCoeff() > kMaxCoordinate)
            throw py::value_error(std::string(name) + " must be finite, within +-1e6 (ccfr's bound on coordinates)");
        };
        bounded(a[0], "anchor"), bounded(c[0], "candidate");
        for (size_t k = 0; k < hs.size(); ++k) {
          if (!hs[k].n.allFinite() || !std::isfinite(hs[k].d) || std::abs(hs[k].d) > kMaxCoordinate ||
              std::abs(hs[k].n.norm() - 1) > 1e-6)
            throw py::value_error("planes row " + std::to_string(k) +
                                  " must hold a unit normal and a finite d within +-1e6");
        }
        ProjectorParams pp;
        pp.epsilon = epsilon;
        pp.max_iterations = max_iterations;
        pp.sweeps = sweeps;
        try {
          validate(pp);  // the bounds of the scene's projector keys
        } catch (const Error& e) {
          throw py::value_error(e.what());
        }
        return make_projector(method, pp)->project(a[0], c[0], hs);
      },
      py::arg("anchor"), py::arg("candidate"), py::arg("planes"), py::arg("method") = "plesnik",
      py::arg("epsilon") = 1e-6, py::arg("max_iterations") = 4, py::arg("sweeps") = 10,
      "project(anchor, candidate, planes, method='plesnik', epsilon=1e-06, max_iterations=4, sweeps=10)\n--\n\n"
      "Projects `candidate` into the region {x : (x - anchor).n_k + d_k >= 0} of the half-spaces `planes` (rows "
      "nx, ny, nz, d; unit normals), by `method` (ccfr.projector_names()).");
}

}  // namespace ccfr::python
