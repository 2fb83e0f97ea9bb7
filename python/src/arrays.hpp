#pragma once
// NumPy arrays in and out of the bindings: real and integer arrays checked and converted to ccfr's
// positions and index rows, and read-only views of position buffers.
#include <vector>

#include "bindings.hpp"
#include "ccfr/core/types.hpp"

namespace ccfr::python {

using RowArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IndexArray = py::array_t<Index, py::array::c_style | py::array::forcecast>;

/// `h` as a float64 array; real numbers only (forcecast would drop a complex part with a warning,
/// or parse strings): other dtypes are a ValueError naming `what`.
RowArray real_array(const py::handle& h, const char* what);
/// An (n, 3) float array as positions; `what` names it in errors.
Positions to_positions(const py::handle& h, const char* what);
/// An (n, N) integer array as index rows (None or empty: none), read in the array's own signedness;
/// another dtype or shape, or an index that does not fit 32 bits, is a ValueError naming `what`.
/// Defined for N = 2, 3 and 4.
template <int N>
std::vector<Eigen::Matrix<Index, N, 1>> to_rows(const py::handle& h, const char* what);
/// A read-only NumPy view of a position buffer, kept alive by `owner`.
py::array view(const Positions& p, py::handle owner);

}  // namespace ccfr::python
