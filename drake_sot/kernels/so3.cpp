// SO(3) and the 6D pose features of Mansard et al. 2009 (FeaturePoint6d): the numpy oracles are
// drake_sot.so3 and drake_sot.features.point6d.
#include <cmath>
#include <stdexcept>
#include <utility>

#include <Eigen/Dense>
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "kernels.h"

namespace py = pybind11;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace drake_sot {
namespace {

// so3.log: rotation vector of R, angle in [0, pi], accurate at both ends.
Vector3d log_so3(const Matrix3d& R) {
  const double vx = R(2, 1) - R(1, 2), vy = R(0, 2) - R(2, 0), vz = R(1, 0) - R(0, 1);
  const double theta =
      std::atan2(0.5 * std::sqrt(vx * vx + vy * vy + vz * vz), 0.5 * (R(0, 0) + R(1, 1) + R(2, 2) - 1.0));
  if (theta < 1e-6) return Vector3d(0.5 * vx, 0.5 * vy, 0.5 * vz);
  if (M_PI - theta < 1e-4) {
    const Vector3d v(vx, vy, vz);
    const double c = std::cos(theta);
    const Matrix3d A = (0.5 * (R + R.transpose()) - c * Matrix3d::Identity()) / (1.0 - c);
    Eigen::Index k;
    A.diagonal().maxCoeff(&k);
    Vector3d axis = A.col(k) / A.col(k).norm();
    if (axis.dot(v) < 0.0) axis = -axis;
    return theta * axis;
  }
  const double scale = theta / (2.0 * std::sin(theta));
  return Vector3d(scale * vx, scale * vy, scale * vz);
}

// so3.left_jacobian_inverse: I - W/2 + coef W^2.
Matrix3d left_jacobian_inverse(const Vector3d& w) {
  const double x = w(0), y = w(1), z = w(2);
  const double theta2 = x * x + y * y + z * z;
  double coef = 1.0 / 12.0;
  if (!(theta2 < 1e-12)) {
    const double theta = std::sqrt(theta2);
    coef = (1.0 - 0.5 * theta / std::tan(0.5 * theta)) / theta2;
  }
  Matrix3d J;
  J << 1.0 + coef * (x * x - theta2), 0.5 * z + coef * x * y, -0.5 * y + coef * x * z,  //
      -0.5 * z + coef * x * y, 1.0 + coef * (y * y - theta2), 0.5 * x + coef * y * z,   //
      0.5 * y + coef * x * z, -0.5 * x + coef * y * z, 1.0 + coef * (z * z - theta2);
  return J;
}

using Jacobian = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor>;
// Any strides: Drake's (6, nv) frame Jacobians arrive in column order, and are read where they are.
using AnyJacobian = Eigen::Ref<const Eigen::MatrixXd, 0, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>>;

// features.point6d without the feed-forward: e = [p - p*; log(R R*ᵀ)], J_e = [J_v; J_l⁻¹(e_o) J_ω].
std::pair<Eigen::Matrix<double, 6, 1>, Jacobian> point6d(const Matrix3d& R, const Vector3d& p, const AnyJacobian& J,
                                                          const Matrix3d& R_des, const Vector3d& p_des) {
  if (J.rows() != 6) throw std::invalid_argument("point6d: J must have 6 rows [ω; v]");
  const Vector3d e_o = log_so3(R * R_des.transpose());
  Eigen::Matrix<double, 6, 1> e;
  e << p - p_des, e_o;
  Jacobian J_e(6, J.cols());
  J_e.topRows<3>() = J.bottomRows<3>();
  J_e.bottomRows<3>().noalias() = left_jacobian_inverse(e_o) * J.topRows<3>();
  return {e, J_e};
}

}  // namespace

void bind_so3(py::module_& m) {
  m.def("so3_log", &log_so3, py::arg("R"), "so3.log: the rotation vector (3,) of R (3, 3).");
  m.def("so3_left_jacobian_inverse", &left_jacobian_inverse, py::arg("w"),
        "so3.left_jacobian_inverse: J_l^{-1}(w) (3, 3).");
  m.def("point6d", &point6d, py::arg("R"), py::arg("p"), py::arg("J"), py::arg("R_des"), py::arg("p_des"),
        "features.point6d without the feed-forward: (e (6,), J_e (6, nv)).");
}

}  // namespace drake_sot
