// The 6D pose features of Mansard et al. 2009 (FeaturePoint6d, FeaturePoint6dRelative) and the
// SO(3) maps they use. Oracles: drake_sot.features.point6d / point6d_relative, drake_sot.so3.
#include <cmath>
#include <optional>

#include <Eigen/Dense>
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "kernels.h"

namespace py = pybind11;
using Eigen::Matrix3d;
using Eigen::Vector3d;
using RowMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using Vector6d = Eigen::Matrix<double, 6, 1>;
// numpy's (3, 3) and (6, nv) arrays are row-major: taken as they are, without a copy.
using Rotation = Eigen::Ref<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>;
using Jacobian = Eigen::Ref<const RowMatrix>;

namespace drake_sot {
namespace {

// so3.log: rotation vector of R, angle in [0, pi], accurate at both ends.
Vector3d log_so3(const Matrix3d& R) {
  const double vx = R(2, 1) - R(1, 2), vy = R(0, 2) - R(2, 0), vz = R(1, 0) - R(0, 1);
  const double theta =
      std::atan2(0.5 * std::sqrt(vx * vx + vy * vy + vz * vz), 0.5 * (R(0, 0) + R(1, 1) + R(2, 2) - 1.0));
  if (theta < 1e-6) return Vector3d(0.5 * vx, 0.5 * vy, 0.5 * vz);
  if (M_PI - theta < 1e-4) {
    // The symmetric part is cos(theta) I + (1 - cos(theta)) a a^T: the axis is read from it.
    const Vector3d v(vx, vy, vz);
    const double c = std::cos(theta);
    const Matrix3d A = (0.5 * (R + R.transpose()) - c * Matrix3d::Identity()) / (1.0 - c);
    Eigen::Index k = 0;
    for (Eigen::Index i = 1; i < 3; ++i)
      if (A(i, i) > A(k, k)) k = i;  // numpy's argmax: the first of equal ones
    Vector3d axis = A.col(k) / A.col(k).norm();
    if (axis.dot(v) < 0.0) axis = -axis;
    return theta * axis;
  }
  const double scale = theta / (2.0 * std::sin(theta));
  return Vector3d(scale * vx, scale * vy, scale * vz);
}

// so3.left_jacobian_inverse: I - W/2 + coef W^2, W^2 = w w^T - theta^2 I written out.
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

Matrix3d hat(const Vector3d& w) {
  Matrix3d W;
  W << 0.0, -w(2), w(1), w(2), 0.0, -w(0), -w(1), w(0), 0.0;
  return W;
}

// features.point6d: e = [p - p*; log(R R*^T)], J_e = [J_v; J_l^{-1}(e_o) J_w], and the
// feed-forward [v*; J_r^{-1}(e_o) w*] of a moving reference (zero without one).
py::tuple point6d(const Rotation& R, const Eigen::Ref<const Vector3d>& p, const Jacobian& J,
                  const Rotation& R_des, const Eigen::Ref<const Vector3d>& p_des,
                  const std::optional<Eigen::Ref<const Vector6d>>& velocity_des) {
  const Vector3d e_o = log_so3(R * R_des.transpose());
  Vector6d e;
  e << p - p_des, e_o;
  RowMatrix J_e(6, J.cols());
  J_e.topRows<3>() = J.bottomRows<3>();
  J_e.bottomRows<3>().noalias() = left_jacobian_inverse(e_o) * J.topRows<3>();
  Vector6d feedforward = Vector6d::Zero();
  if (velocity_des) {
    const Vector6d& v = *velocity_des;
    feedforward << v.head<3>(), left_jacobian_inverse(-e_o) * v.tail<3>();
  }
  return py::make_tuple(e, J_e, feedforward);
}

// features.point6d_relative: the pose of frame a in frame b against a desired relative pose.
py::tuple point6d_relative(const Rotation& R_a, const Eigen::Ref<const Vector3d>& p_a, const Jacobian& J_a,
                           const Rotation& R_b, const Eigen::Ref<const Vector3d>& p_b, const Jacobian& J_b,
                           const Rotation& R_des, const Eigen::Ref<const Vector3d>& p_des) {
  const Vector3d d = p_a - p_b;
  const Matrix3d Rb_T = R_b.transpose();
  const Vector3d e_o = log_so3(Rb_T * R_a * R_des.transpose());
  Vector6d e;
  e << Rb_T * d - p_des, e_o;
  RowMatrix J_e(6, J_a.cols());
  J_e.topRows<3>().noalias() = Rb_T * (J_a.bottomRows<3>() - J_b.bottomRows<3>() + hat(d) * J_b.topRows<3>());
  J_e.bottomRows<3>().noalias() = (left_jacobian_inverse(e_o) * Rb_T) * (J_a.topRows<3>() - J_b.topRows<3>());
  return py::make_tuple(e, J_e);
}

}  // namespace

void bind_features(py::module_& m) {
  m.def("point6d", &point6d, py::arg("R"), py::arg("p"), py::arg("J"), py::arg("R_des"), py::arg("p_des"),
        py::arg("velocity_des") = py::none(), "features.point6d: (e (6,), J_e (6, nv), feedforward (6,)).");
  m.def("point6d_relative", &point6d_relative, py::arg("R_a"), py::arg("p_a"), py::arg("J_a"), py::arg("R_b"),
        py::arg("p_b"), py::arg("J_b"), py::arg("R_des"), py::arg("p_des"),
        "features.point6d_relative: (e (6,), J_e (6, nv)).");
}

}  // namespace drake_sot
