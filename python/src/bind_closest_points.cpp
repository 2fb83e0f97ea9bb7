// The closest-point kernels from Python: point_edge, point_triangle and edge_edge, each returning a
// dict of the closest points, parameters, distance and feature.
#include <cmath>

#include "arrays.hpp"
#include "bindings.hpp"
#include "ccfr/geometry/distance.hpp"

namespace ccfr::python {

void define_closest_points(py::module_& m) {
  auto vec = [](const py::object& o, const char* what) {
    return to_positions(real_array(o, what).reshape({1, 3}), what)[0];
  };
  auto arr = [](const Vec3& v) { return py::array_t<double>(3, v.data()); };
  m.def(
      "point_edge",
      [vec, arr](const py::object& p, const py::object& a, const py::object& b) {
        const auto r = point_edge(vec(p, "p"), vec(a, "a"), vec(b, "b"));
        py::dict d;
        d["closest"] = arr(r.closest), d["t"] = r.t, d["distance"] = std::sqrt(r.distance_sq);
        d["feature"] = r.feature == EdgeFeature::v0 ? "v0" : r.feature == EdgeFeature::v1 ? "v1" : "interior";
        return d;
      },
      py::arg("p"), py::arg("a"), py::arg("b"),
      "point_edge(p, a, b)\n--\n\nClosest point of segment ab to p: dict closest, t (closest = a + t (b - a)), "
      "distance, feature.");
  m.def(
      "point_triangle",
      [vec, arr](const py::object& p, const py::object& a, const py::object& b, const py::object& c) {
        const auto r = point_triangle(vec(p, "p"), vec(a, "a"), vec(b, "b"), vec(c, "c"));
        static const char* names[] = {"v0", "v1", "v2", "e01", "e12", "e20", "interior"};
        py::dict d;
        d["closest"] = arr(r.closest), d["bary"] = arr(r.bary), d["distance"] = std::sqrt(r.distance_sq);
        d["feature"] = names[static_cast<int>(r.feature)];
        return d;
      },
      py::arg("p"), py::arg("a"), py::arg("b"), py::arg("c"),
      "point_triangle(p, a, b, c)\n--\n\nClosest point of triangle abc to p: dict closest, bary (barycentrics), "
      "distance, feature.");
  m.def(
      "edge_edge",
      [vec, arr](const py::object& a0, const py::object& a1, const py::object& b0, const py::object& b1) {
        const auto r = edge_edge(vec(a0, "a0"), vec(a1, "a1"), vec(b0, "b0"), vec(b1, "b1"));
        py::dict d;
        d["pa"] = arr(r.pa), d["pb"] = arr(r.pb), d["s"] = r.s, d["t"] = r.t;
        d["distance"] = std::sqrt(r.distance_sq), d["parallel"] = r.parallel;
        return d;
      },
      py::arg("a0"), py::arg("a1"), py::arg("b0"), py::arg("b1"),
      "edge_edge(a0, a1, b0, b1)\n--\n\nClosest points of segments a0a1 and b0b1: dict pa, pb, s, t, distance, "
      "parallel.");
}

}  // namespace ccfr::python
