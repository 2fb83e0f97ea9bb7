// NumPy conversions of the bindings (arrays.hpp): dtype and shape checks with errors naming the
// argument, copies into Positions and index rows, read-only views of Positions.
#include "arrays.hpp"

#include <limits>
#include <string>
#include <string_view>
#include <utility>

namespace ccfr::python {

RowArray real_array(const py::handle& h, const char* what) {
  if (py::array raw = py::array::ensure(h);
      raw && raw.size() > 0 && std::string_view("fiub").find(raw.dtype().kind()) == std::string_view::npos)
    throw py::value_error(std::string(what) + " must hold real numbers (got dtype " +
                          std::string(py::str(raw.dtype())) + ")");
  return RowArray::ensure(h);
}

Positions to_positions(const py::handle& h, const char* what) {
  RowArray a = real_array(h, what);
  if (!a || a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error(std::string(what) + " must be an (n, 3) array of numbers");
  Positions p(static_cast<size_t>(a.shape(0)));
  auto r = a.unchecked<2>();
  for (py::ssize_t i = 0; i < a.shape(0); ++i) p[i] = Vec3(r(i, 0), r(i, 1), r(i, 2));
  return p;
}

template <int N>
std::vector<Eigen::Matrix<Index, N, 1>> to_rows(const py::handle& h, const char* what) {
  std::vector<Eigen::Matrix<Index, N, 1>> out;
  if (h.is_none()) return out;
  py::array raw = py::array::ensure(h);
  if (!raw) throw py::value_error(std::string(what) + " must be an (n, " + std::to_string(N) + ") integer array");
  if (raw.size() == 0) return out;
  if (raw.dtype().kind() != 'i' && raw.dtype().kind() != 'u')
    throw py::value_error(std::string(what) + " must hold integers (got dtype " + std::string(py::str(raw.dtype())) +
                          ")");
  if (raw.ndim() != 2 || raw.shape(1) != N)
    throw py::value_error(std::string(what) + " must be an (n, " + std::to_string(N) + ") integer array");
  // Read in the array's own signedness: 2**63 as uint64 is not the int64 -2**63.
  const auto copy = [&]<class T>(T) {
    py::array_t<T, py::array::c_style | py::array::forcecast> a(raw);
    auto r = a.template unchecked<2>();
    out.resize(static_cast<size_t>(a.shape(0)));
    for (py::ssize_t i = 0; i < a.shape(0); ++i)
      for (int k = 0; k < N; ++k) {
        const T v = r(i, k);
        // Out-of-range indices are reported by the loader with the object's key path; only values
        // that do not fit an index are refused here.
        if (std::cmp_less(v, std::numeric_limits<Index>::min()) ||
            std::cmp_greater(v, std::numeric_limits<Index>::max()))
          throw py::value_error(std::string(what) + " row " + std::to_string(i) + ": index " + std::to_string(v) +
                                " does not fit 32 bits");
        out[i][k] = static_cast<Index>(v);
      }
  };
  if (raw.dtype().kind() == 'u')
    copy((unsigned long long)0);
  else
    copy((long long)0);
  return out;
}

template std::vector<Eigen::Matrix<Index, 2, 1>> to_rows<2>(const py::handle& h, const char* what);
template std::vector<Eigen::Matrix<Index, 3, 1>> to_rows<3>(const py::handle& h, const char* what);
template std::vector<Eigen::Matrix<Index, 4, 1>> to_rows<4>(const py::handle& h, const char* what);

py::array view(const Positions& p, py::handle owner) {
  py::array a(py::dtype::of<double>(), {static_cast<py::ssize_t>(p.size()), py::ssize_t{3}},
              {static_cast<py::ssize_t>(sizeof(Vec3)), static_cast<py::ssize_t>(sizeof(double))},
              p.empty() ? nullptr : p.front().data(), owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}
static_assert(sizeof(Vec3) == 3 * sizeof(double), "Positions must be a packed (n, 3) array for the NumPy views");

}  // namespace ccfr::python
