// The torque family of Liu, Lober, Padois 2016: the projected Jacobians J_i P_i(A_i) of eq. 8 and
// the task-space inertia weighting of eq. 2 (K_P = k_p Λ, K_D = k_d Λ). The numpy oracles (and
// fallbacks) are drake_sot.generalized.ProjectedJacobians and drake_sot.generalized.inertia_weighted;
// each function here follows its oracle step by step (same rows, same order, same thresholds), so
// that both agree to rounding.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

// GCC warns of an uninitialised workspace inside Eigen 3.4's triangular products (a false positive,
// -Wmaybe-uninitialized): silenced in Eigen's headers only.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <Eigen/Dense>
#pragma GCC diagnostic pop
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "kernels.h"

namespace py = pybind11;
using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace drake_sot {
namespace {

using RowMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using Starts = Eigen::Ref<const Eigen::Matrix<std::int64_t, Eigen::Dynamic, 1>>;
// Any strides (a transposed or sliced numpy array is read where it is, not copied).
using AnyMatrix = Eigen::Ref<const MatrixXd, 0, Eigen::Stride<Eigen::Dynamic, Eigen::Dynamic>>;

// generalized._unit: the rows that are not exactly zero, scaled to unit length (a row whose squared
// norm would overflow or underflow is first divided by its largest |entry|). kept[j] is where row j
// of `rows` would begin among the unit rows (kept[m] their count).
Index unit_rows(const AnyMatrix& rows, RowMatrixXd& unit, std::vector<Index>& kept) {
  const Index m = rows.rows();
  unit.resize(m, rows.cols());
  kept.assign(m + 1, 0);
  Index k = 0;
  for (Index i = 0; i < m; ++i) {
    kept[i] = k;
    const double norm = rows.row(i).norm();
    if (norm > 1e-140 && norm < 1e140) {
      unit.row(k++) = rows.row(i) / norm;
      continue;
    }
    const double peak = rows.row(i).cwiseAbs().maxCoeff();
    if (!(peak > 0.0)) continue;  // a zero row (a switched-off component) constrains nothing
    unit.row(k) = rows.row(i) / peak;
    unit.row(k) /= unit.row(k).norm();
    ++k;
  }
  kept[m] = k;
  return k;
}

// generalized._basis: (B, w) of P = I - B diag(w) Bᵀ from the unit rows of `order` (tasks by
// decreasing alpha, task j's unit rows [first[j], first[j + 1])), one group of equal alpha at a time.
Index basis(const RowMatrixXd& unit, const std::vector<Index>& first, const std::vector<Index>& order,
            const std::vector<double>& alpha, double tol, MatrixXd& B, VectorXd& w) {
  const Index nv = unit.cols();
  B.resize(nv, nv);
  w.resize(nv);
  Index r = 0;
  MatrixXd group;  // the group's rows, as columns (nv, k_g)
  for (std::size_t begin = 0; begin < order.size();) {
    if (r == nv) break;
    const double a = alpha[order[begin]];
    std::size_t end = begin;
    Index count = 0;
    while (end < order.size() && alpha[order[end]] == a) {
      count += first[order[end] + 1] - first[order[end]];
      ++end;
    }
    group.resize(nv, count);
    Index c = 0;
    for (std::size_t t = begin; t < end; ++t) {
      const Index j = order[t], m = first[j + 1] - first[j];
      group.middleCols(c, m) = unit.middleRows(first[j], m).transpose();
      c += m;
    }
    begin = end;
    const auto Br = B.leftCols(r);
    if (r) group -= Br * (Br.transpose() * group);
    MatrixXd q;
    double smallest;
    if (count == 1) {  // one row: a Gram-Schmidt step, no factorisation
      const double norm = group.col(0).norm();
      if (norm <= tol) continue;
      q = group / norm;
      smallest = norm;
    } else {  // group Π = Q R, |R_kk| decreasing: the new directions are Q's first k columns
      const Eigen::ColPivHouseholderQR<MatrixXd> qr(group);
      const VectorXd d = qr.matrixQR().diagonal().cwiseAbs();
      const Index k = std::min<Index>((d.array() > tol).count(), nv - r);
      if (k == 0) continue;
      q = MatrixXd::Identity(nv, k);
      qr.householderQ().setLength(k).applyThisOnTheLeft(q);
      smallest = d(k - 1);
    }
    if (r && smallest < 1e-4) q -= Br * (Br.transpose() * q);  // "twice is enough"
    const Index k = q.cols();
    B.middleCols(r, k) = q;
    w.segment(r, k).setConstant(a);
    r += k;
  }
  return r;
}

// ProjectedJacobians.__call__: out = J_i P_i(A_i) of every task, task i's rows of `stacked` being
// [starts[i], starts[i + 1]); tasks with the same α row share one basis.
void projected_jacobians(const AnyMatrix& stacked, const AnyMatrix& alpha, const Starts& starts, double tol,
                         Eigen::Ref<RowMatrixXd> out) {
  const Index n = alpha.rows(), m = stacked.rows(), nv = stacked.cols();
  if (alpha.cols() != n || starts.size() != n + 1 || starts(0) != 0 || starts(n) != m)
    throw std::invalid_argument("projected_jacobians: alpha (" + std::to_string(alpha.rows()) + ", " +
                                std::to_string(alpha.cols()) + ") and starts (" +
                                std::to_string(starts.size()) + ",) do not describe the " +
                                std::to_string(m) + " stacked rows");
  if (out.rows() != m || out.cols() != nv)
    throw std::invalid_argument("projected_jacobians: out must have the shape of stacked");
  for (Index i = 0; i < n; ++i)
    if (starts(i + 1) < starts(i)) throw std::invalid_argument("projected_jacobians: starts decrease");
  RowMatrixXd unit;
  std::vector<Index> kept;
  unit_rows(stacked, unit, kept);
  std::vector<Index> first(n + 1), sizes(n);  // each task's unit rows
  for (Index j = 0; j <= n; ++j) first[j] = kept[starts(j)];
  for (Index j = 0; j < n; ++j) sizes[j] = first[j + 1] - first[j];
  out = stacked;
  std::vector<bool> done(n, false);
  std::vector<double> row(n);
  std::vector<Index> order;
  MatrixXd B, JB;
  VectorXd w;
  for (Index i = 0; i < n; ++i) {
    if (done[i]) continue;
    for (Index j = 0; j < n; ++j) row[j] = alpha(i, j);
    order.clear();
    for (Index j = 0; j < n; ++j)
      if (row[j] > 0.0 && sizes[j]) order.push_back(j);
    std::stable_sort(order.begin(), order.end(), [&](Index a, Index b) { return row[a] > row[b]; });
    const Index r = order.empty() ? 0 : basis(unit, first, order, row, tol, B, w);
    const bool unweighted = !order.empty() && row[order.front()] == 1.0 && row[order.back()] == 1.0;
    for (Index k = i; k < n; ++k) {  // every task with this α row
      if (done[k] || (k > i && !(alpha.row(k).array() == alpha.row(i).array()).all())) continue;
      done[k] = true;
      const Index b = starts(k), e = starts(k + 1);
      if (e == b || r == 0) continue;  // P = I: out holds J_k already
      const auto Bv = B.leftCols(r);
      JB.noalias() = stacked.middleRows(b, e - b) * Bv;
      if (!unweighted) JB *= w.head(r).asDiagonal();
      out.middleRows(b, e - b).noalias() -= JB * Bv.transpose();
    }
  }
}

// generalized.inertia_weighted: Λ_i a_i for every task, Λ_i = (J_i M⁻¹ J_iᵀ)⁻¹ by Cholesky, task
// i's rows of J being [starts[i], starts[i + 1]); zero rows of J get zero. None where the numpy
// version would not take the Cholesky path (M not positive definite, or some task's rows dependent
// or nearly so): the caller then runs the numpy version (its error, or its pseudo-inverses).
std::optional<VectorXd> inertia_weighted(const AnyMatrix& J, const std::vector<Index>& starts,
                                         const AnyMatrix& M, const Eigen::Ref<const VectorXd>& accelerations,
                                         double independent) {
  const Index m = J.rows(), nv = J.cols();
  if (M.rows() != nv || M.cols() != nv || accelerations.size() != m || starts.empty() || starts.front() != 0 ||
      starts.back() != m)
    throw std::invalid_argument("inertia_weighted: J (" + std::to_string(m) + ", " + std::to_string(nv) +
                                "), M (" + std::to_string(M.rows()) + ", " + std::to_string(M.cols()) +
                                "), accelerations (" + std::to_string(accelerations.size()) +
                                ",) and the task starts do not match");
  const Eigen::LLT<MatrixXd> llt(M);
  if (llt.info() != Eigen::Success) return std::nullopt;
  MatrixXd Y = J.transpose();
  llt.matrixL().solveInPlace(Y);  // Y = L⁻¹ Jᵀ, J M⁻¹ Jᵀ = Yᵀ Y
  VectorXd out(m);
  MatrixXd A;
  VectorXd a;
  for (std::size_t t = 0; t + 1 < starts.size(); ++t) {
    const Index b = starts[t], k = starts[t + 1] - b;
    if (k < 0) throw std::invalid_argument("inertia_weighted: task starts decrease");
    if (!k) continue;
    const auto Yi = Y.middleCols(b, k);
    A.noalias() = Yi.transpose() * Yi;
    a = accelerations.segment(b, k);
    for (Index i = 0; i < k; ++i)
      if (!(J.row(b + i).array() != 0.0).any()) {  // inactive row: 1 on the diagonal, zero right-hand side
        A(i, i) += 1.0;
        a(i) = 0.0;
      }
    const VectorXd diagonal = A.diagonal();
    const Eigen::LLT<MatrixXd> factor(A);
    // L_kk² / A_kk: the squared relative distance of row k to the rows before it (M⁻¹ metric).
    if (factor.info() != Eigen::Success ||
        !(factor.matrixLLT().diagonal().array().square() >= independent * diagonal.array()).all())
      return std::nullopt;
    factor.solveInPlace(a);
    out.segment(b, k) = a;
  }
  return out;
}

}  // namespace

void bind_generalized(py::module_& m) {
  m.def("projected_jacobians", &projected_jacobians, py::arg("stacked"), py::arg("alpha"), py::arg("starts"),
        py::arg("tol"), py::arg("out").noconvert(),
        "ProjectedJacobians.__call__: J_i P_i(A_i) of every task into out (Σ m_i, nv), C-contiguous float64.");
  m.def("inertia_weighted", &inertia_weighted, py::arg("J"), py::arg("starts"), py::arg("M"),
        py::arg("accelerations"), py::arg("independent"),
        "inertia_weighted's Cholesky path: Λ_i a_i (Σ m_i,), or None where the numpy version must run.");
}

}  // namespace drake_sot
