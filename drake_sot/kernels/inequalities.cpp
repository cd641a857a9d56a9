// The distance damper's rows for pairs of bodies (self-collision avoidance; Kanoun, Lamiraux,
// Wieber 2011's velocity damper). Oracle: drake_sot.inequalities.distance_rows_numpy.
#include <cmath>
#include <limits>
#include <optional>

#include <Eigen/Dense>
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "kernels.h"

namespace py = pybind11;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

namespace drake_sot {
namespace {

// (error, J, lower, upper) of k pairs in `rows` rows: J_i = n_i^T (J_A,i - J_B,i), the rate of the
// distance d_i bounded below by gain (d_s - d_i) (recovery (d_s - d_i) inside the margin, when given),
// error d_i - d_s where negative; rows k.. zero and unbounded.
py::tuple distance_rows(const Eigen::Ref<const Eigen::VectorXd>& distances,
                        const Eigen::Ref<const RowMatrix>& normals, py::array_t<double, py::array::c_style> J_a,
                        py::array_t<double, py::array::c_style> J_b, double margin, double gain, Eigen::Index rows,
                        std::optional<double> recovery) {
  const Eigen::Index k = distances.size();
  if (k > rows) throw py::value_error(std::to_string(k) + " pairs of bodies: more than the " +
                                      std::to_string(rows) + " rows");
  if (J_a.ndim() != 3 || J_b.ndim() != 3 || J_a.shape(0) != k || J_b.shape(0) != k || J_a.shape(1) != 3 ||
      J_b.shape(1) != 3 || J_a.shape(2) != J_b.shape(2) || normals.rows() != k || normals.cols() != 3)
    throw py::value_error("distance_rows: shapes must be distances (k,), normals (k, 3), J_a and J_b (k, 3, nv)");
  const Eigen::Index nv = J_a.shape(2);
  constexpr double inf = std::numeric_limits<double>::infinity();
  Eigen::VectorXd error = Eigen::VectorXd::Zero(rows), lower = Eigen::VectorXd::Constant(rows, -inf),
                  upper = Eigen::VectorXd::Constant(rows, inf);
  RowMatrix J = RowMatrix::Zero(rows, nv);
  const double* a = J_a.data();
  const double* b = J_b.data();
  for (Eigen::Index i = 0; i < k; ++i) {
    using Block = Eigen::Map<const Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor>>;
    const Block A(a + i * 3 * nv, 3, nv), B(b + i * 3 * nv, 3, nv);
    J.row(i).noalias() = normals.row(i) * (A - B);
    const double d = distances(i);
    error(i) = d - std::max(d, margin);  // outside(d, margin, inf)
    lower(i) = (recovery && d < margin) ? *recovery * (margin - d) : gain * (margin - d);
    upper(i) = inf;  // velocity_bounds' upper side: gain (inf - d)
  }
  return py::make_tuple(error, J, lower, upper);
}

}  // namespace

void bind_inequalities(py::module_& m) {
  m.def("distance_rows", &distance_rows, py::arg("distances"), py::arg("normals"), py::arg("J_a"), py::arg("J_b"),
        py::arg("margin"), py::arg("gain"), py::arg("rows"), py::arg("recovery") = py::none(),
        "inequalities.distance_rows: (error (rows,), J (rows, nv), lower (rows,), upper (rows,)).");
}

}  // namespace drake_sot
