// SO(3) and the 6D pose features of Mansard et al. 2009 (FeaturePoint6d): the numpy oracles are
// drake_sot.so3 and drake_sot.features.point6d.
#include <cmath>

#include <Eigen/Dense>
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>

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

}  // namespace

void bind_so3(py::module_& m) {
  m.def("so3_log", &log_so3, py::arg("R"), "so3.log: the rotation vector (3,) of R (3, 3).");
  m.def("so3_left_jacobian_inverse", &left_jacobian_inverse, py::arg("w"),
        "so3.left_jacobian_inverse: J_l^{-1}(w) (3, 3).");
}

}  // namespace drake_sot
