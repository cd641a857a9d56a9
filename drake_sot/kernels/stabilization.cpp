// The DCM stabilizer's tick (eq. 2-3 of drake_sot.stabilization: the desired ZMP of the divergent
// component's feedback, projected into the support polygon shrunk by a margin, and the CoM offset
// driven by the filtered measured ZMP, semi-implicit Euler). Oracles: stabilization.stabilizer_step
// and project_into_polygon's numpy versions; the same checks, raised as ValueError.
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

#include <Eigen/Dense>
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>

#include "kernels.h"

namespace py = pybind11;
using Eigen::Vector2d;
using Polygon = Eigen::Matrix<double, Eigen::Dynamic, 2, Eigen::RowMajor>;

namespace drake_sot {
namespace {

constexpr double kCoordinateBound = 1e6;  // stabilization.COORDINATE_BOUND
constexpr double kInLine = 1e-12;         // stabilization._IN_LINE
constexpr double kOmegaMin = 1e-3, kOmegaMax = 1e3;  // stabilization.OMEGA_BOUNDS

std::string listed(const Polygon& p) {
  std::ostringstream out;
  out.precision(17);
  out << "[";
  for (Eigen::Index i = 0; i < p.rows(); ++i) out << (i ? ", [" : "[") << p(i, 0) << ", " << p(i, 1) << "]";
  out << "]";
  return out.str();
}

// _convex_counter_clockwise: vertices repeated or in line dropped, a clockwise polygon reversed.
std::vector<Vector2d> convex_counter_clockwise(const Polygon& given) {
  if (given.rows() < 3)
    throw py::value_error("polygon has " + std::to_string(given.rows()) +
                          " vertices: a support polygon needs at least 3");
  if (!(given.cwiseAbs().maxCoeff() <= kCoordinateBound))
    throw py::value_error("polygon: a coordinate beyond ±1e+06 m");
  std::vector<Vector2d> v;
  for (Eigen::Index i = 0; i < given.rows(); ++i) v.emplace_back(given(i, 0), given(i, 1));
  std::vector<double> turn;
  while (true) {
    const std::size_t k = v.size();
    double scale = 0.0;
    std::vector<Vector2d> edge(k);  // edge i ends at vertex i
    for (std::size_t i = 0; i < k; ++i) {
      edge[i] = v[i] - v[(i + k - 1) % k];
      scale = std::max(scale, edge[i].cwiseAbs().maxCoeff());
    }
    if (k < 3 || !(scale > 0.0))
      throw py::value_error("polygon " + listed(given) +
                            ": fewer than 3 vertices once those repeated or in line are dropped");
    turn.assign(k, 0.0);
    std::size_t flat = k;
    for (std::size_t i = 0; i < k; ++i) {
      const Vector2d a = edge[i] / scale, b = edge[(i + 1) % k] / scale;
      turn[i] = a(0) * b(1) - a(1) * b(0);
      if (flat == k && std::abs(turn[i]) <= kInLine) flat = i;
    }
    if (flat == k) break;
    v.erase(v.begin() + static_cast<std::ptrdiff_t>(flat));
  }
  bool all_negative = true, all_positive = true;
  std::size_t positive = 0;
  for (double t : turn) {
    all_negative &= t < 0.0;
    all_positive &= t > 0.0;
    positive += t > 0.0;
  }
  if (all_negative) return {v.rbegin(), v.rend()};
  if (!all_positive) {
    std::size_t i = 0;
    for (std::size_t j = 1; j < turn.size(); ++j)
      if (positive > turn.size() / 2 ? turn[j] < turn[i] : turn[j] > turn[i]) i = j;
    std::ostringstream out;
    out.precision(17);
    out << "polygon " << listed(given) << ": turns both ways at vertex [" << v[i](0) << ", " << v[i](1)
        << "]: the vertices must be a convex polygon's, in order";
    throw py::value_error(out.str());
  }
  return v;
}

// project_into_polygon: the point of the polygon shrunk by margin nearest to point.
Vector2d project(const Polygon& polygon, const Vector2d& point, double margin) {
  if (!(point.cwiseAbs().maxCoeff() <= kCoordinateBound))
    throw py::value_error("point: a coordinate beyond ±1e+06 m, or not finite");
  if (!(margin >= 0.0) || !std::isfinite(margin)) throw py::value_error("margin must be finite and >= 0 m");
  const std::vector<Vector2d> v = convex_counter_clockwise(polygon);
  const std::size_t k = v.size();
  std::vector<Vector2d> normal(k);
  std::vector<double> offset(k);
  bool inside = true;
  for (std::size_t i = 0; i < k; ++i) {
    const Vector2d e = v[(i + 1) % k] - v[i];
    normal[i] = Vector2d(-e(1), e(0)) / e.norm();
    offset[i] = normal[i].dot(v[i]) + margin;
    inside &= normal[i].dot(point) >= offset[i];
  }
  if (inside) return point;
  std::vector<Vector2d> w(k);  // the shrunk polygon's vertices (Cramer's rule)
  for (std::size_t i = 0; i < k; ++i) {
    const Vector2d& b = normal[(i + k - 1) % k];
    const double ob = offset[(i + k - 1) % k];
    const double det = b(0) * normal[i](1) - b(1) * normal[i](0);
    w[i] = Vector2d((ob * normal[i](1) - b(1) * offset[i]) / det, (b(0) * offset[i] - ob * normal[i](0)) / det);
  }
  for (std::size_t i = 0; i < k; ++i)
    for (std::size_t j = 0; j < k; ++j)
      if (normal[i].dot(w[j]) < offset[i] - 1e-9) {
        std::ostringstream out;
        out << "margin = " << margin << " m: larger than the support polygon's inradius";
        throw py::value_error(out.str());
      }
  Vector2d best = w[0];
  double best_gap = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < k; ++i) {
    const Vector2d ab = w[(i + 1) % k] - w[i];
    const double length2 = ab.dot(ab);
    const double s = length2 > 0.0 ? std::clamp((point - w[i]).dot(ab) / length2, 0.0, 1.0) : 0.0;
    const Vector2d candidate = w[i] + s * ab;
    const double gap = (point - candidate).squaredNorm();
    if (gap < best_gap) best_gap = gap, best = candidate;
  }
  return best;
}

// stabilizer_step, with the hands' load given as the desired ZMP's base (zmp_ref, or eq. 6's
// zmp of the hands) and the feedback's scale (1, or eq. 2''s).
py::tuple stabilizer_step(const Vector2d& offset, const Vector2d& offset_rate, const Vector2d& zmp_filtered,
                          const Vector2d& com_ref, const Vector2d& com_vel_ref, const Vector2d& zmp_base,
                          const Vector2d& com, const Vector2d& com_vel, const Vector2d& zmp, const Polygon& polygon,
                          double omega, double dt, double feedback_scale, double k_dcm, double k_zmp, double damping,
                          double zmp_filter, double max_offset, double margin) {
  if (!(omega >= kOmegaMin && omega <= kOmegaMax))
    throw py::value_error("omega must be within [0.001, 1000] 1/s");
  if (!(dt > 0.0) || !std::isfinite(dt)) throw py::value_error("dt must be finite and > 0 s");
  if (!(zmp_filter >= 0.0) || !std::isfinite(zmp_filter))
    throw py::value_error("tau must be finite and >= 0 s");
  const Vector2d xi = com + com_vel / omega, xi_ref = com_ref + com_vel_ref / omega;
  if (!xi.allFinite() || !xi_ref.allFinite()) throw py::value_error("divergent component: not finite");
  const Vector2d raw = zmp_base + (1.0 + k_dcm / omega) * feedback_scale * (xi - xi_ref);
  const Vector2d desired = project(polygon, raw, margin);
  // low_pass: no measurement (NaN) keeps the filtered ZMP; none filtered yet takes the measurement.
  Vector2d filtered = zmp_filtered;
  if (zmp.allFinite()) filtered = zmp_filtered.allFinite() ? Vector2d(zmp_filtered + dt / (zmp_filter + dt) * (zmp - zmp_filtered)) : zmp;
  const Vector2d pull = filtered.allFinite() ? Vector2d(-k_zmp * (desired - filtered)) : Vector2d::Zero();
  Vector2d rate = offset_rate + (pull - damping * offset_rate) * dt;
  const Vector2d moved = offset + rate * dt;
  const Vector2d bounded = moved.cwiseMax(-max_offset).cwiseMin(max_offset);
  bool held_any = false;
  for (int i = 0; i < 2; ++i)
    if (bounded(i) != moved(i)) rate(i) = 0.0, held_any = true;
  return py::make_tuple(bounded, rate, filtered, desired, desired != raw, held_any);
}

// support.support_polygon: Andrew's monotone chain, counter-clockwise, points on an edge dropped;
// the ties of the sort broken by index, as Python's stable sort of (x, y).
Polygon support_polygon(const Polygon& points) {
  const Eigen::Index n = points.rows();
  std::vector<Eigen::Index> order(n);
  for (Eigen::Index i = 0; i < n; ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) {
    return points(a, 0) < points(b, 0) || (points(a, 0) == points(b, 0) && points(a, 1) < points(b, 1));
  });
  auto cross = [&](Eigen::Index o, Eigen::Index a, Eigen::Index b) {
    return (points(a, 0) - points(o, 0)) * (points(b, 1) - points(o, 1)) -
           (points(a, 1) - points(o, 1)) * (points(b, 0) - points(o, 0));
  };
  auto chain = [&](const std::vector<Eigen::Index>& indices) {
    std::vector<Eigen::Index> hull;
    for (Eigen::Index i : indices) {
      while (hull.size() >= 2 && cross(hull[hull.size() - 2], hull.back(), i) <= 0.0) hull.pop_back();
      hull.push_back(i);
    }
    return hull;
  };
  const std::vector<Eigen::Index> lower = chain(order);
  const std::vector<Eigen::Index> upper = chain({order.rbegin(), order.rend()});
  std::vector<Eigen::Index> vertices(lower.begin(), lower.end() - (lower.empty() ? 0 : 1));
  vertices.insert(vertices.end(), upper.begin(), upper.end() - (upper.empty() ? 0 : 1));
  Polygon hull(static_cast<Eigen::Index>(vertices.size()), 2);
  for (std::size_t k = 0; k < vertices.size(); ++k) hull.row(static_cast<Eigen::Index>(k)) = points.row(vertices[k]);
  return hull;
}

}  // namespace

void bind_stabilization(py::module_& m) {
  m.def("support_polygon", &support_polygon, py::arg("points"),
        "support.support_polygon: the convex hull (k, 2), counter-clockwise, of the points (n, 2).");
  m.def("project_into_polygon", &project, py::arg("polygon"), py::arg("point"), py::arg("margin"),
        "stabilization.project_into_polygon: the nearest point of the polygon shrunk by margin.");
  m.def("stabilizer_step", &stabilizer_step, py::arg("offset"), py::arg("offset_rate"), py::arg("zmp_filtered"),
        py::arg("com_ref"), py::arg("com_vel_ref"), py::arg("zmp_base"), py::arg("com"), py::arg("com_vel"),
        py::arg("zmp"), py::arg("polygon"), py::arg("omega"), py::arg("dt"), py::arg("feedback_scale"),
        py::arg("k_dcm"), py::arg("k_zmp"), py::arg("damping"), py::arg("zmp_filter"), py::arg("max_offset"),
        py::arg("margin"),
        "stabilization.stabilizer_step: (offset, offset_rate, zmp_filtered, zmp_desired, zmp_saturated, "
        "offset_saturated).");
}

}  // namespace drake_sot
